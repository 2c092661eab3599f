#pragma once
// plexus::Error -> the Python exceptions of plexus._errors (Error and one subclass per ErrorCode).

#include <pybind11/pybind11.h>

namespace plexus::python {

/// Makes every plexus::Error thrown through a binding raise plexus.<Kind>Error with its message.
void register_error_translator();

}  // namespace plexus::python
