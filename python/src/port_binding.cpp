#include "port_binding.hpp"

#include <pybind11/stl.h>

#include <chrono>
#include <optional>

#include "blob_write.hpp"
#include "conversion.hpp"

namespace py = pybind11;

namespace plexus::python {

namespace {

using Clock = std::chrono::steady_clock;

// A blocking read waits in slices this long, between which it takes the GIL back to run signal
// handlers: Ctrl-C interrupts a read within this time. A message ends a slice at once, so this
// costs no latency.
constexpr std::chrono::milliseconds read_slice{50};

/// A received message: its data and its envelope.
struct Message {
    py::object data;
    Envelope envelope;
};

std::optional<Received> read_slice_released(PythonPort& self, std::chrono::milliseconds wait) {
    py::gil_scoped_release release;
    std::lock_guard lock(self.read_mutex);
    return self.port.read(wait);
}

/// Waits up to `timeout` seconds (None: for ever) for the next message; None when none came.
py::object read(PythonPort& self, std::optional<double> timeout) {
    if (timeout && *timeout < 0)
        throw Error(ErrorCode::usage, "timeout must be >= 0 seconds");
    const auto deadline = timeout ? Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                                       std::chrono::duration<double>(*timeout))
                                  : Clock::time_point::max();
    for (;;) {
        const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
        const auto wait = std::clamp(left, std::chrono::milliseconds(0), read_slice);
        if (auto received = read_slice_released(self, wait)) {
            Message message{to_python(received->data), std::move(received->envelope)};
            return py::cast(std::move(message));
        }
        if (PyErr_CheckSignals() != 0)  // Ctrl-C: KeyboardInterrupt from here
            throw py::error_already_set();
        if (Clock::now() >= deadline)
            return py::none();
    }
}

void write(PythonPort& self, py::handle object, bool flush) {
    if (write_borrowed_blob(self, object, flush))
        return;  // an array or bytes alone: sent from its own memory, no Value in between
    Value value = to_value(object);
    py::gil_scoped_release release;  // a strict reader slows writers down: others run meanwhile
    std::lock_guard lock(self.write_mutex);
    self.port.write(value, flush);
}

bool is_open(PythonPort& self) {
    py::gil_scoped_release release;
    std::lock_guard lock(self.read_mutex);  // close() changes it under both locks
    return self.port.is_open();
}

void close(PythonPort& self) {
    py::gil_scoped_release release;
    std::scoped_lock lock(self.read_mutex, self.write_mutex);
    self.port.close();
}

}  // namespace

void bind_port(py::module_& module) {
    py::class_<Envelope>(module, "Envelope",
                         "Where a message comes from: its source port, sequence number and time.")
        .def_readonly("source", &Envelope::source, "The port that wrote the message.")
        .def_readonly("seq", &Envelope::seq, "The source's sequence number, from 1.")
        .def_readonly("time_ns", &Envelope::time_ns, "Send time, ns since the Unix epoch.")
        .def_property_readonly(
            "time", [](const Envelope& e) { return static_cast<double>(e.time_ns) / 1e9; },
            "Send time, seconds since the Unix epoch (float).")
        .def("__repr__", [](const Envelope& e) {
            return "Envelope(source=" + py::repr(py::str(e.source)).cast<std::string>() +
                   ", seq=" + std::to_string(e.seq) + ", time_ns=" + std::to_string(e.time_ns) + ")";
        });

    py::class_<Message>(module, "Message", "A received message: `data` and `envelope`.")
        .def_readonly("data", &Message::data,
                      "The payload, as Python objects (blobs as bytes or numpy.ndarray).")
        .def_readonly("envelope", &Message::envelope, "Source, sequence number and send time.")
        .def("__repr__", [](const Message& m) {
            return "Message(data=" + py::repr(m.data).cast<std::string>() +
                   ", envelope=" + py::repr(py::cast(m.envelope)).cast<std::string>() + ")";
        });

    // dynamic_attr: the asyncio methods (plexus/_asyncio.py) keep a reader thread per port.
    py::class_<PythonPort>(module, "Port", py::dynamic_attr(),
                           "A port opened by a Client (Client.open). Closing it flushes what was written.")
        .def_property_readonly(
            "name", [](const PythonPort& self) { return self.port.name(); }, "The port's name.")
        .def_property_readonly("is_open", &is_open, "False once closed.")
        .def("write", &write, py::arg("data"), py::arg("flush") = true,
             "Writes a message to every connection out of this port. data: dict (str keys), list, "
             "tuple, str, int, float, bool, None, bytes/bytearray/memoryview (a blob) or numpy.ndarray "
             "(a blob holding a .npy file); an array or bytes written alone is sent from its own memory, "
             "which may be changed as soon as write returns. With flush=False it waits in a buffer "
             "until the next flushing write or flush(). May block while a strict reader is behind (the "
             "GIL is released).")
        .def(
            "flush",
            [](PythonPort& self) {
                py::gil_scoped_release release;
                std::lock_guard lock(self.write_mutex);
                self.port.flush();
            },
            "Sends what write(..., flush=False) buffered.")
        .def("read", &read, py::arg("timeout") = py::none(),
             "Waits up to `timeout` seconds (None: for ever, 0: only what is there) for the next "
             "message; returns a Message, or None if none came. Ctrl-C interrupts it "
             "(KeyboardInterrupt).")
        .def("close", &close, "Flushes and closes the port; further reads and writes raise UsageError.")
        .def_property_readonly(
            "dropped_while_disconnected",
            [](const PythonPort& self) { return self.port.dropped_while_disconnected(); },
            "Messages written while the daemon was away and dropped (the oldest) beyond the bound.")
        .def("__iter__", [](py::object self) { return self; })
        .def(
            "__next__",
            [](PythonPort& self) {
                try {
                    return read(self, std::nullopt);
                } catch (const Error&) {
                    if (!is_open(self))  // closed before or during the wait: the end of the messages
                        throw py::stop_iteration();
                    throw;
                }
            },
            "The next message, waiting for ever; the iteration ends when the port is closed.")
        .def("__enter__", [](py::object self) { return self; })
        .def("__exit__", [](PythonPort& self, py::args) { close(self); })
        .def("__repr__", [](const PythonPort& self) {
            return "<plexus.Port " + self.port.name() + (self.port.is_open() ? "" : " (closed)") + ">";
        });
}

}  // namespace plexus::python
