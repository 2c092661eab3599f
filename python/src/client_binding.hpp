#pragma once
// The Python Client: a connection to the local daemon (plexus::Client).

#include <pybind11/pybind11.h>

namespace plexus::python {

/// Adds Client to the module.
void bind_client(pybind11::module_& module);

}  // namespace plexus::python
