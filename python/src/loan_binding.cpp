#include "loan_binding.hpp"

#include <pybind11/stl.h>

#include <chrono>
#include <optional>
#include <span>

#include "conversion.hpp"
#include "port_binding.hpp"

namespace py = pybind11;

namespace plexus::python {

namespace {

/// A loan until it is sent: after send_loan its memory belongs to the message (and, once the
/// readers are done, to later loans), so the buffer is no longer handed out.
struct PythonLoan {
    std::optional<Loan> loan;
};

struct PythonView {
    std::optional<MessageView> view;
};

Loan& live(PythonLoan& self) {
    if (!self.loan)
        throw Error(ErrorCode::usage, "this loan was sent: take a new one with Port.loan");
    return *self.loan;
}

MessageView& live(PythonView& self) {
    if (!self.view)
        throw Error(ErrorCode::usage, "this view was released");
    return *self.view;
}

PythonLoan loan(PythonPort& self, std::size_t size) {
    py::gil_scoped_release release;  // the first loan of a port asks the daemon for its region
    std::lock_guard lock(self.write_mutex);
    return PythonLoan{self.port.loan(size)};
}

void send_loan(PythonPort& self, PythonLoan& loan, bool flush) {
    Loan taken = std::move(live(loan));
    loan.loan.reset();
    py::gil_scoped_release release;
    std::lock_guard lock(self.write_mutex);
    self.port.send_loan(std::move(taken), flush);
}

py::object read_view(PythonPort& self, std::optional<double> timeout) {
    if (timeout && *timeout < 0)
        throw Error(ErrorCode::usage, "timeout must be >= 0 seconds");
    // One wait, with the GIL released (a view is for large messages at a high rate: Ctrl-C is
    // seen when the wait ends, at most `timeout` later; None waits for ever).
    std::optional<MessageView> view;
    {
        py::gil_scoped_release release;
        std::lock_guard lock(self.read_mutex);
        const auto wait = timeout ? std::chrono::milliseconds(static_cast<long long>(*timeout * 1000))
                                  : std::chrono::milliseconds(std::chrono::hours(24 * 365));
        view = self.port.read_view(wait);
    }
    if (!view)
        return py::none();
    return py::cast(PythonView{std::move(view)});
}

}  // namespace

void bind_loans(py::module_& module) {
    py::class_<PythonLoan>(module, "Loan", py::buffer_protocol(),
                           "A buffer for one blob message (Port.loan): write into it in place — "
                           "memoryview(loan), numpy.frombuffer(loan, dtype) — then Port.send_loan(loan). "
                           "In the port's shared memory when the daemon is on this machine: a reader "
                           "there reads it without a copy. Sent, it is an empty buffer; do not use "
                           "views taken before.")
        .def_buffer([](PythonLoan& self) {
            // No exception here (pybind11 cannot turn one thrown from a buffer request into a
            // Python error): a sent loan is an empty buffer.
            std::span<std::uint8_t> bytes;
            if (self.loan)
                bytes = self.loan->bytes();
            return py::buffer_info(bytes.data(), 1, py::format_descriptor<std::uint8_t>::format(), 1,
                                   {static_cast<py::ssize_t>(bytes.size())}, {1}, false);
        })
        .def("__len__", [](PythonLoan& self) { return live(self).bytes().size(); })
        .def_property_readonly(
            "in_shared_memory", [](PythonLoan& self) { return live(self).in_shared_memory(); },
            "True when the bytes lie in shared memory (not copied again on this machine).");

    py::class_<PythonView>(module, "MessageView", py::buffer_protocol(),
                           "A message read in place (Port.read_view): memoryview(view) is the blob's "
                           "bytes, read-only, in shared memory when in_place. Release it (release(), "
                           "or a with block) soon: the writer's slot is held until then.")
        .def_buffer([](PythonView& self) {
            std::span<const std::uint8_t> bytes;  // a released view is an empty buffer (see Loan)
            if (self.view)
                bytes = self.view->bytes();
            return py::buffer_info(const_cast<std::uint8_t*>(bytes.data()), 1,
                                   py::format_descriptor<std::uint8_t>::format(), 1,
                                   {static_cast<py::ssize_t>(bytes.size())}, {1}, true);
        })
        .def_property_readonly("envelope", [](PythonView& self) { return live(self).envelope(); })
        .def_property_readonly(
            "in_place", [](PythonView& self) { return live(self).in_place(); },
            "True when the bytes are read where the writer put them (no copy was made).")
        .def(
            "value",
            [](PythonView& self) {
                Value value = live(self).value();
                return to_python(value);
            },
            "The message as Python objects (a copy).")
        .def(
            "release", [](PythonView& self) { self.view.reset(); },
            "Lets go of the message (its memory must not be used after).")
        .def("__enter__", [](py::object self) { return self; })
        .def("__exit__", [](PythonView& self, py::args) { self.view.reset(); });

    auto port = py::reinterpret_borrow<py::class_<PythonPort>>(module.attr("Port"));
    port.def("loan", &loan, py::arg("size"),
             "A Loan of `size` bytes for one blob message, in this port's shared memory when it can be.")
        .def("send_loan", &send_loan, py::arg("loan"), py::arg("flush") = true,
             "Sends a filled Loan as one blob message (the loan cannot be used after).")
        .def("read_view", &read_view, py::arg("timeout") = py::none(),
             "Like read, but returns a MessageView: a blob written on this machine in shared "
             "memory is read in place, without a copy; None if no message came in time.");
}

}  // namespace plexus::python
