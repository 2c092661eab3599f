#pragma once
// Writing a blob from the memory of the Python object that holds it (a NumPy array, bytes,
// bytearray, memoryview), without building a Value first. Called with the GIL held; the one copy
// of the data, into the socket or the shared-memory slot, is made without it.

#include <pybind11/pybind11.h>

#include "port_binding.hpp"

namespace plexus::python {

/// Writes `object` as a blob straight from its buffer when it is a numpy.ndarray (a .npy blob)
/// or a bytes-like object, and returns true; false, having written nothing, for anything else.
/// The buffer is only read during the call: the object may be changed once it returns.
bool write_borrowed_blob(PythonPort& port, pybind11::handle object, bool flush);

}  // namespace plexus::python
