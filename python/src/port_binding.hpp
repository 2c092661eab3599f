#pragma once
// The Python Port, Message and Envelope.
//
// Threading: Python threads may share a Port. Its reads are serialized by read_mutex and its
// writes by write_mutex (libplexus allows one reader and one writer at a time per port), each
// taken with the GIL released, so a thread blocked in read() never holds up the others.

#include <pybind11/pybind11.h>

#include <mutex>

#include <plexus/client.hpp>

namespace plexus::python {

struct PythonPort {
    explicit PythonPort(Port opened) : port(std::move(opened)) {}
    Port port;
    std::mutex read_mutex;
    std::mutex write_mutex;
};

/// Adds Port, Message and Envelope to the module.
void bind_port(pybind11::module_& module);

}  // namespace plexus::python
