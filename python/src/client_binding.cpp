#include "client_binding.hpp"

#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <plexus/proto/port_name.hpp>

#include "call_binding.hpp"
#include "conversion.hpp"
#include "errors.hpp"
#include "plexus/proto/name_operations.hpp"
#include "plexus/proto/operations.hpp"
#include "port_binding.hpp"

namespace py = pybind11;

namespace plexus::python {

namespace {

std::unique_ptr<Client> make_client(const std::optional<std::string>& socket, double request_timeout) {
    Client::Options options;
    options.socket = socket.value_or("");
    options.request_timeout = std::chrono::milliseconds(static_cast<long long>(request_timeout * 1000));
    py::gil_scoped_release release;  // connecting and the hello wait on the daemon
    return std::make_unique<Client>(options);
}

std::unique_ptr<PythonPort> open(Client& client, const std::string& name, const std::string& policy,
                                 std::size_t capacity) {
    require_port_name(name);
    if (policy != "strict" && policy != "latest")
        throw Error(ErrorCode::usage, "policy must be \"strict\" or \"latest\", not \"" + policy + "\"");
    PortOptions options{policy == "latest" ? QueuePolicy::latest : QueuePolicy::strict, capacity};
    py::gil_scoped_release release;
    return std::make_unique<PythonPort>(client.open(name, options));
}

/// A control request with the GIL released; the reply as Python objects.
py::object ask(Client& client, const Value& body) {
    Value reply;
    {
        py::gil_scoped_release release;
        reply = client.request(body);
    }
    return to_python(reply);
}

/// Sends `request` (a request struct of plexus/proto/) and gives its answer, read through `Answer`,
/// as Python; an answer that does not decode raises RefusedError.
template <class Answer, class Request>
py::object ask_as(Client& client, const Request& request) {
    Value reply;
    {
        py::gil_scoped_release release;
        reply = client.request(request.encode());
    }
    auto decoded = Answer::decode(reply);
    if (!decoded)
        throw Error(ErrorCode::refused, decoded.error().message);
    Value answer = decoded->encode();
    return to_python(answer);
}

bool exists(Client& client, const std::string& port, const std::optional<std::string>& destination) {
    require_port_name(port);
    if (!destination) {
        py::gil_scoped_release release;
        return client.lookup(port).has_value();
    }
    require_port_name(*destination);
    Value answer;
    {
        py::gil_scoped_release release;
        answer = client.list();
    }
    // As `plexus exists SRC DST`: a connection the name server knows and that is up.
    for (const auto& c : answer.value("connections", Value::array())) {
        if (c.value("source", "") == port && c.value("destination", "") == *destination &&
            c.value("live", false))
            return true;
    }
    return false;
}

}  // namespace

void bind_client(py::module_& module) {
    py::class_<Client> client(
        module, "Client",
        "A connection to the local daemon. socket: its Unix socket (None: $PLEXUS_SOCKET, "
        "else the per-user runtime path, as the C++ Client and the CLI). Raises RefusedError "
        "saying where it looked if no daemon runs there. Reconnects by itself if the daemon "
        "restarts.");
    client
        .def(py::init(&make_client), py::arg("socket") = py::none(), py::arg("request_timeout") = 10.0,
             "Connects to the local daemon.")
        .def_property_readonly("socket_path", &Client::socket_path,
                               "The socket path this client is connected to.")
        .def("open", &open, py::arg("name"), py::arg("policy") = "strict", py::arg("capacity") = 0,
             py::keep_alive<0, 1>(),
             "Opens a port on the local daemon and registers it with the name server. policy: \"strict\" "
             "(nothing dropped: writers slow down) or \"latest\" (keep the newest `capacity`); capacity 0: "
             "the daemon's default.")
        .def(
            "connect",
            [](Client& client, const std::string& source, const std::string& destination,
               const std::string& carrier, bool persist) {
                require_port_name(source);
                require_port_name(destination);
                py::gil_scoped_release release;
                return client.connect(source, destination, carrier, persist);
            },
            py::arg("source"), py::arg("destination"), py::arg("carrier") = "", py::arg("persist") = false,
            "Connects two ports (anywhere); carrier \"\" chooses local or tcp by where they live. Returns "
            "the "
            "carrier used. Raises RefusedError when the daemon refuses (e.g. a port that does not exist).")
        .def(
            "disconnect",
            [](Client& client, const std::string& source, const std::string& destination) {
                require_port_name(source);
                require_port_name(destination);
                py::gil_scoped_release release;
                client.disconnect(source, destination);
            },
            py::arg("source"), py::arg("destination"), "Removes the connection source -> destination.")
        .def("exists", &exists, py::arg("port"), py::arg("destination") = py::none(),
             "True if the port is registered; with a destination, if the connection port -> destination "
             "is up (as `plexus exists`).")
        .def(
            "lookup",
            [](Client& client, const std::string& port) -> py::object {
                require_port_name(port);
                std::optional<Value> where;
                {
                    py::gil_scoped_release release;
                    where = client.lookup(port);
                }
                return where ? to_python(*where) : py::none();
            },
            py::arg("port"),
            "Where a port lives ({\"port\", \"node\", \"address\"}), or None if it is not registered.")
        .def(
            "list", [](Client& client) { return ask_as<proto::ListReply>(client, proto::ListRequest{}); },
            "Ports and connections as the name server knows them: {\"ports\": [...], \"connections\": "
            "[...]}.")
        .def(
            "stats",
            [](Client& client, const std::string& port) {
                if (!port.empty())
                    require_port_name(port);
                return ask_as<proto::StatsReply>(client, proto::StatsRequest{port});
            },
            py::arg("port") = "",
            "Counters of the local daemon, or of the daemon hosting `port` (as `plexus stats --json`).")
        .def(
            "events",
            [](Client& client, const std::string& port, bool check) {
                require_port_name(port);
                return ask_as<proto::EventsReply>(client, proto::EventsRequest{port, check});
            },
            py::arg("port"), py::arg("check") = false,
            "The arbitration of an input port (as `plexus events PORT --json`): event container, "
            "constraints, stimulation, counters; check=True adds the constraints' overlaps.")
        .def(
            "ping",
            [](Client& client, const std::string& port) {
                require_port_name(port);
                return ask_as<proto::PingReply>(client, proto::PingRequest{port});
            },
            py::arg("port"), "Asks the daemon hosting `port` to answer; returns its node and address.")
        .def(
            "request", [](Client& client, py::handle body) { return ask(client, to_value(body)); },
            py::arg("body"), "Sends any control request (a dict with \"op\") and returns the reply.")
        .def("__repr__", [](const Client& client) { return "<plexus.Client " + client.socket_path() + ">"; });
    bind_calls(module, client);
}

}  // namespace plexus::python
