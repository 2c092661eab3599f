#include "errors.hpp"

#include <plexus/client.hpp>
#include <plexus/proto/port_name.hpp>

namespace py = pybind11;

namespace plexus::python {

namespace {

/// plexus._errors.from_code, looked up once. Kept for the life of the process on purpose: a
/// py::object in a static would be released after the interpreter is gone.
PyObject* from_code() {
    static PyObject* function =
        py::object(py::module_::import("plexus._errors").attr("from_code")).release().ptr();
    return function;
}

void raise(const Error& error) {
    try {
        py::object exception = py::reinterpret_borrow<py::object>(from_code())(static_cast<int>(error.code()),
                                                                               std::string(error.what()));
        PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(exception.ptr())), exception.ptr());
    } catch (py::error_already_set& failure) {
        failure.restore();  // the module could not be imported: that error is more useful
    }
}

}  // namespace

void register_error_translator() {
    py::register_exception_translator([](std::exception_ptr pending) {
        try {
            if (pending)
                std::rethrow_exception(pending);
        } catch (const Error& error) {
            raise(error);
        }
    });
}

void require_port_name(const std::string& name) {
    if (auto error = proto::port_name_error(name))
        throw Error(ErrorCode::usage, *error);
}

}  // namespace plexus::python
