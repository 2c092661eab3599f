// _plexus: the compiled half of the Python package plexus (python/plexus/__init__.py is the other).
#include <pybind11/pybind11.h>

#include "client_binding.hpp"
#include "errors.hpp"
#include "loan_binding.hpp"
#include "port_binding.hpp"
#include "recording_binding.hpp"

PYBIND11_MODULE(_plexus, module) {
    module.doc() =
        "libplexus for Python: Client, Port, Message, Envelope, Recording. Import plexus, not this.";
    plexus::python::register_error_translator();
    plexus::python::bind_port(module);
    plexus::python::bind_loans(module);
    plexus::python::bind_client(module);
    plexus::python::bind_recording(module);
}
