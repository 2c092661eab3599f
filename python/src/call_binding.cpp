#include "call_binding.hpp"

#include <chrono>
#include <memory>
#include <optional>

#include <plexus/proto/port_name.hpp>

#include "conversion.hpp"
#include "errors.hpp"

namespace py = pybind11;

namespace plexus::python {

namespace {

std::chrono::milliseconds milliseconds_of(double seconds) {
    if (!(seconds > 0) || seconds > 86'400)
        throw Error(ErrorCode::usage, "timeout must be more than 0 and at most 86400 seconds");
    return std::chrono::milliseconds(static_cast<long long>(seconds * 1000.0 + 0.5));
}

/// The Python exception for `error`, as the translator raises it (plexus._errors).
py::object exception_of(const Error& error) {
    static const char* names[] = {"Error", "NotFoundError", "UsageError", "TimeoutError", "RefusedError"};
    const auto code = static_cast<int>(error.code());
    const char* name = code >= 1 && code <= 4 ? names[code] : names[0];
    return py::module_::import("plexus._errors").attr(name)(error.what());
}

/// A Service whose handler is Python: it is stopped with the GIL released (its thread may be
/// waiting for the GIL to call the handler).
struct PythonService {
    std::optional<Service> service;
    std::string port;

    void close() {
        if (!service)
            return;
        py::gil_scoped_release release;
        service.reset();
    }
    ~PythonService() {
        if (service && Py_IsInitialized()) {
            py::gil_scoped_acquire gil;  // a destructor may run without it
            close();
        }
    }
};

}  // namespace

void bind_calls(py::module_& module, py::class_<Client>& client) {
    py::class_<PythonService>(module, "Service",
                              "Answers the calls of one served port until closed (or used as a context "
                              "manager and left).")
        .def_readonly("port", &PythonService::port, "The port it serves.")
        .def_property_readonly(
            "calls", [](const PythonService& s) { return s.service ? s.service->calls() : 0; },
            "Calls handed to the handler so far.")
        .def("close", &PythonService::close, "Stops answering and closes the port.")
        .def(
            "__enter__", [](PythonService& s) -> PythonService& { return s; },
            py::return_value_policy::reference)
        .def("__exit__", [](PythonService& s, py::args) { s.close(); });

    client
        .def(
            "request",
            [](Client& client, const std::string& port, py::handle value, double timeout) {
                require_port_name(port);
                const Value request = to_value(value);
                const auto wait = milliseconds_of(timeout);
                Received reply;
                {
                    py::gil_scoped_release release;
                    reply = client.request(port, request, wait);
                }
                return to_python(reply.data);
            },
            py::arg("port"), py::arg("value"), py::arg("timeout") = 10.0,
            "Calls the service at `port` with `value` and returns the answer's value (docs/CALLS.md). "
            "Raises TimeoutError when no answer came within `timeout` seconds, RefusedError with the "
            "reason when no server was selectable, its handler failed, or it went away. (With one "
            "argument, a dict with \"op\", request sends a control request instead.)")
        .def(
            "_request_then",
            [](Client& client, const std::string& port, py::handle value, double timeout, py::function done) {
                require_port_name(port);
                const Value request = to_value(value);
                const auto wait = milliseconds_of(timeout);
                // Released wherever the last copy goes (the receiving thread): with the GIL.
                auto callback =
                    std::shared_ptr<py::function>(new py::function(std::move(done)), [](py::function* f) {
                        py::gil_scoped_acquire gil;
                        delete f;
                    });
                py::gil_scoped_release release;
                client.request_then(port, request, wait, [callback](Received* reply, const Error* error) {
                    py::gil_scoped_acquire gil;
                    try {
                        if (reply)
                            (*callback)(to_python(reply->data), py::none());
                        else
                            (*callback)(py::none(), exception_of(*error));
                    } catch (py::error_already_set& e) {
                        e.discard_as_unraisable("plexus request_async completion");
                    }
                });
            },
            py::arg("port"), py::arg("value"), py::arg("timeout"), py::arg("done"),
            "For request_async: calls done(value, None) or done(None, exception) once, from a thread of "
            "the client.")
        .def(
            "serve",
            [](Client& client, const std::string& port, py::function handler) {
                require_port_name(port);
                auto shared =
                    std::shared_ptr<py::function>(new py::function(std::move(handler)), [](py::function* f) {
                        py::gil_scoped_acquire gil;
                        delete f;
                    });
                auto service = std::make_unique<PythonService>();
                service->port = port;
                py::gil_scoped_release release;
                service->service.emplace(client.serve(port, [shared](const Received& request) -> Value {
                    py::gil_scoped_acquire gil;
                    try {
                        Value copy = request.data;
                        py::object answer = (*shared)(to_python(copy));
                        return to_value(answer);
                    } catch (py::error_already_set& e) {
                        throw std::runtime_error(e.what());  // the call fails with the handler's error
                    }
                }));
                return service;
            },
            py::arg("port"), py::arg("handler"), py::keep_alive<0, 1>(),
            "Opens `port` to serve it: each call is answered with handler(value), called on a thread of "
            "the client, one call at a time; an exception fails the call with its text. Returns the "
            "Service (close it, or use it in a with block).");
}

}  // namespace plexus::python
