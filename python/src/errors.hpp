#pragma once
// plexus::Error -> the Python exceptions of plexus._errors (Error and one subclass per ErrorCode).

#include <pybind11/pybind11.h>

#include <string>

namespace plexus::python {

/// Makes every plexus::Error thrown through a binding raise plexus.<Kind>Error with its message.
void register_error_translator();

/// Refuses a bad port name with the CLI's message (a UsageError), before asking the daemon.
void require_port_name(const std::string& name);

}  // namespace plexus::python
