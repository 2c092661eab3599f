#pragma once
// Request/reply for Python: Client.request (a call), Client.serve and Service, and the hook the
// asyncio half uses (Client._request_then). docs/CALLS.md says what calls are.

#include <pybind11/pybind11.h>

#include <plexus/client.hpp>

namespace plexus::python {

/// Adds the call methods to the Client class already bound (client_binding.cpp) and binds Service.
void bind_calls(pybind11::module_& module, pybind11::class_<Client>& client);

}  // namespace plexus::python
