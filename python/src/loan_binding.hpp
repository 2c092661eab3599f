#pragma once
// The Python Loan and MessageView: zero-copy messages (libplexus's Port::loan, send_loan, read_view).
//
// Threading: a Loan or a MessageView is used by one Python thread at a time (the GIL); the port's
// write_mutex / read_mutex are taken as for write() and read().

#include <pybind11/pybind11.h>

namespace plexus::python {

/// Adds Loan and MessageView to the module, and Port.loan, Port.send_loan, Port.read_view.
void bind_loans(pybind11::module_& module);

}  // namespace plexus::python
