#pragma once
// NumPy arrays as blobs holding a .npy file (the format is described in plexus/_ndarray.py).
// Called with the GIL held. NumPy is imported only when an array is sent or a .npy blob arrives.

#include <pybind11/pybind11.h>

#include <cstdint>
#include <vector>

#include <plexus/client.hpp>

namespace plexus::python {

/// True if `object` is a numpy.ndarray (false without importing NumPy when nobody has).
bool is_ndarray(pybind11::handle object);

/// True if `object` is a NumPy scalar (numpy.float32(1.5), numpy.int64(3), ...).
bool is_numpy_scalar(pybind11::handle object);

/// The blob for an array: the .npy header, then the array's bytes copied once, straight from its
/// buffer (a non-contiguous array is made contiguous first).
Value ndarray_to_blob(pybind11::handle array);

/// The ndarray a .npy blob holds, viewing `bytes` (taken over and kept alive by the array), or
/// an empty object (bytes left untouched) if the blob is not a .npy file this can read.
pybind11::object blob_to_ndarray(std::vector<std::uint8_t>& bytes);

}  // namespace plexus::python
