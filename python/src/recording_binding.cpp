#include "recording_binding.hpp"

#include <pybind11/stl.h>

#include "conversion.hpp"
#include "plexus/recording.hpp"

namespace plexus::python {

namespace py = pybind11;

namespace {

/// One recorded message as Python sees it: its payload decoded as Port.read decodes one.
struct PythonRecordedMessage {
    RecordedMessage message;
    py::object data() const {
        Value value = message.value();
        return to_python(value);
    }
};

/// The messages of the ports asked for, at most `limit` (0: all): for a recording larger than
/// memory, ask for fewer ports or a limit.
std::vector<PythonRecordedMessage> messages_of(const Recording& recording,
                                               const std::vector<std::string>& ports, std::size_t limit) {
    std::vector<PythonRecordedMessage> out;
    py::gil_scoped_release released;  // reading and decompressing need no Python
    recording.for_each(
        [&](const RecordedMessage& message) {
            out.push_back({message});
            return limit == 0 || out.size() < limit;
        },
        ports);
    return out;
}

}  // namespace

void bind_recording(py::module_& module) {
    py::class_<PythonRecordedMessage>(
        module, "RecordedMessage",
        "A recorded message: the port it reached, the port that sent it, its times "
        "(ns since the Unix epoch) and its payload exactly as sent.")
        .def_property_readonly("port", [](const PythonRecordedMessage& m) { return m.message.port; })
        .def_property_readonly("source", [](const PythonRecordedMessage& m) { return m.message.source; })
        .def_property_readonly("sequence", [](const PythonRecordedMessage& m) { return m.message.sequence; })
        .def_property_readonly("sent_ns", [](const PythonRecordedMessage& m) { return m.message.sent_ns; })
        .def_property_readonly("arrived_ns",
                               [](const PythonRecordedMessage& m) { return m.message.arrived_ns; })
        .def_property_readonly("payload",
                               [](const PythonRecordedMessage& m) {
                                   const auto& bytes = m.message.payload;
                                   return py::bytes(reinterpret_cast<const char*>(bytes.data()),
                                                    bytes.size());
                               })
        .def_property_readonly("data", &PythonRecordedMessage::data,
                               "The payload decoded, as Port.read gives it.")
        .def("__repr__", [](const PythonRecordedMessage& m) {
            return "<plexus.RecordedMessage " + m.message.source + " -> " + m.message.port + " seq " +
                   std::to_string(m.message.sequence) + ">";
        });

    py::class_<Recording>(
        module, "Recording",
        "A recording made by `plexus record`: Recording(path) opens it; a file that is not one, "
        "or is truncated or corrupt, raises RefusedError naming the offset.")
        .def(py::init([](const std::string& path) { return Recording::open(path); }), py::arg("path"))
        .def_property_readonly("ports", &Recording::ports)
        .def_property_readonly("node", &Recording::node)
        .def_property_readonly("message_count", &Recording::message_count)
        .def_property_readonly("start_ns", &Recording::start_ns)
        .def_property_readonly("end_ns", &Recording::end_ns)
        .def_property_readonly("size_bytes", &Recording::size_bytes)
        .def_property_readonly("end_note", &Recording::end_note,
                               "The daemon's closing note (messages, lost_messages, reason...); empty when "
                               "the recording did not end cleanly.")
        .def_property_readonly("connections",
                               [](const Recording& r) {
                                   py::list out;
                                   for (const auto& c : r.connections()) {
                                       py::dict entry;
                                       entry["port"] = c.port;
                                       entry["source"] = c.source;
                                       entry["carrier"] = c.carrier;
                                       entry["messages"] = c.messages;
                                       out.append(entry);
                                   }
                                   return out;
                               })
        .def("messages", &messages_of, py::arg("ports") = std::vector<std::string>{}, py::arg("limit") = 0,
             "The messages that reached `ports` (every recorded port when empty), in the order they arrived; "
             "at most `limit` of them (0: all).")
        .def("__repr__", [](const Recording& r) {
            return "<plexus.Recording of " + std::to_string(r.ports().size()) + " ports, " +
                   std::to_string(r.message_count()) + " messages>";
        });
}

}  // namespace plexus::python
