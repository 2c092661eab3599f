#pragma once
// Python objects <-> plexus::Value (nlohmann::json). Called with the GIL held.
//
// dict (str keys) <-> map, list/tuple -> array -> list, str, int (64-bit, signed or not), float,
// bool, None, bytes/bytearray/memoryview -> blob -> bytes, numpy.ndarray <-> blob holding a .npy
// file (ndarray.hpp). NumPy scalars are sent as the Python number they hold.

#include <pybind11/pybind11.h>

#include <plexus/client.hpp>

namespace plexus::python {

/// The Value for a Python object; throws TypeError (py::type_error) for what has no equivalent.
Value to_value(pybind11::handle object);

/// The Python object for a Value. Takes the blobs out of `value` (an ndarray then views their
/// memory instead of copying it), so `value` is left partly moved-from.
pybind11::object to_python(Value& value);

}  // namespace plexus::python
