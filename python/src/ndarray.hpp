#pragma once
// NumPy arrays as blobs holding a .npy file (the format is described in plexus/_ndarray.py).
// Called with the GIL held. NumPy is imported only when an array is sent or a .npy blob arrives.

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <span>
#include <vector>

#include <plexus/client.hpp>

namespace plexus::python {

/// True if `object` is a numpy.ndarray (false without importing NumPy when nobody has).
bool is_ndarray(pybind11::handle object);

/// True if `object` is a NumPy scalar (numpy.float32(1.5), numpy.int64(3), ...).
bool is_numpy_scalar(pybind11::handle object);

/// An array as the two parts of its .npy blob, without copying its data: the header made for it
/// and the array's own bytes. Holds the array (or, for a strided view, the one contiguous copy
/// that cannot be avoided), so the bytes stay valid while this lives.
struct NpyParts {
    pybind11::array array;
    pybind11::bytes header;
    std::span<const std::uint8_t> head() const;
    std::span<const std::uint8_t> body() const;
};
NpyParts npy_parts(pybind11::handle array);

/// The blob for an array inside a message (a map, a list): the .npy header, then the array's
/// bytes copied once, straight from its buffer (a non-contiguous array is made contiguous first).
/// An array written alone takes npy_parts and no copy here (blob_write.hpp).
Value ndarray_to_blob(pybind11::handle array);

/// The ndarray a .npy blob holds, viewing `bytes` (taken over and kept alive by the array), or
/// an empty object (bytes left untouched) if the blob is not a .npy file this can read.
pybind11::object blob_to_ndarray(std::vector<std::uint8_t>& bytes);

}  // namespace plexus::python
