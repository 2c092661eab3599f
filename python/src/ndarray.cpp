#include "ndarray.hpp"

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <cstring>
#include <string_view>

namespace py = pybind11;

namespace plexus::python {

namespace {

constexpr std::string_view npy_magic{"\x93NUMPY", 6};
// Copies at least this large are done without the GIL: other Python threads run meanwhile.
constexpr std::size_t copy_without_gil = 256 * 1024;

/// numpy from sys.modules, or null if nobody imported it (then nothing can be an ndarray).
PyObject* numpy_if_imported() {
    static PyObject* numpy = nullptr;
    if (!numpy) {
        PyObject* found = PyDict_GetItemString(PyImport_GetModuleDict(), "numpy");  // borrowed
        if (found) {
            Py_INCREF(found);  // kept for the life of the process, as the functions below
            numpy = found;
        }
    }
    return numpy;
}

/// A function of plexus._ndarray, looked up once and kept for the life of the process.
py::handle helper(const char* name) {
    return py::object(py::module_::import("plexus._ndarray").attr(name)).release();
}

py::handle encode_header() {
    static py::handle function = helper("encode_header");
    return function;
}

py::handle decode_header() {
    static py::handle function = helper("decode_header");
    return function;
}

}  // namespace

bool is_ndarray(py::handle object) {
    PyObject* numpy = numpy_if_imported();
    if (!numpy)
        return false;
    static PyObject* ndarray = PyObject_GetAttrString(numpy, "ndarray");
    return PyObject_TypeCheck(object.ptr(), reinterpret_cast<PyTypeObject*>(ndarray));
}

bool is_numpy_scalar(py::handle object) {
    PyObject* numpy = numpy_if_imported();
    if (!numpy)
        return false;
    static PyObject* generic = PyObject_GetAttrString(numpy, "generic");
    return PyObject_TypeCheck(object.ptr(), reinterpret_cast<PyTypeObject*>(generic));
}

std::span<const std::uint8_t> NpyParts::head() const {
    return {reinterpret_cast<const std::uint8_t*>(PyBytes_AS_STRING(header.ptr())),
            static_cast<std::size_t>(PyBytes_GET_SIZE(header.ptr()))};
}

std::span<const std::uint8_t> NpyParts::body() const {
    return {static_cast<const std::uint8_t*>(array.data()), static_cast<std::size_t>(array.nbytes())};
}

NpyParts npy_parts(py::handle object) {
    auto array = py::reinterpret_borrow<py::array>(object);
    const bool c_order = (array.flags() & py::array::c_style) != 0;
    const bool fortran_order = !c_order && (array.flags() & py::array::f_style) != 0;
    if (!c_order && !fortran_order)  // a strided view: one copy to make it contiguous is unavoidable
        array = py::reinterpret_steal<py::array>(
            py::module_::import("numpy").attr("ascontiguousarray")(array).release());
    py::tuple shape(array.ndim());
    for (py::ssize_t i = 0; i < array.ndim(); ++i)
        shape[static_cast<std::size_t>(i)] = py::int_(array.shape(i));
    py::bytes header = encode_header()(array.dtype(), shape, fortran_order);
    return NpyParts{std::move(array), std::move(header)};
}

Value ndarray_to_blob(py::handle object) {
    const NpyParts parts = npy_parts(object);
    const auto head = parts.head();
    const auto body = parts.body();
    // Straight from the array's buffer into the Value's: no Python bytes object in between, and
    // reserve + insert does not zero the bytes first.
    std::vector<std::uint8_t> bytes;
    bytes.reserve(head.size() + body.size());
    bytes.insert(bytes.end(), head.begin(), head.end());
    if (body.size() >= copy_without_gil) {
        py::gil_scoped_release release;  // `parts` holds the array, so its buffer stays
        bytes.insert(bytes.end(), body.begin(), body.end());
    } else {
        bytes.insert(bytes.end(), body.begin(), body.end());
    }
    return Value::binary(std::move(bytes));
}

py::object blob_to_ndarray(std::vector<std::uint8_t>& bytes) {
    if (bytes.size() < npy_magic.size() + 4 ||
        std::memcmp(bytes.data(), npy_magic.data(), npy_magic.size()) != 0)
        return {};
    const std::uint8_t version = bytes[npy_magic.size()];
    const std::size_t length_bytes = version == 1 ? 2 : (version == 2 || version == 3) ? 4 : 0;
    const std::size_t body_at = npy_magic.size() + 2 + length_bytes;
    if (length_bytes == 0 || bytes.size() < body_at)
        return {};
    std::size_t body_size = 0;
    for (std::size_t i = 0; i < length_bytes; ++i)
        body_size |= static_cast<std::size_t>(bytes[npy_magic.size() + 2 + i]) << (8 * i);
    if (body_size > bytes.size() - body_at)
        return {};
    const std::size_t data_at = body_at + body_size;
    const py::object decoded =
        decode_header()(py::bytes(reinterpret_cast<const char*>(bytes.data() + body_at), body_size));
    if (decoded.is_none())
        return {};
    const auto fields = py::reinterpret_borrow<py::tuple>(decoded);
    const auto dtype = py::reinterpret_borrow<py::dtype>(fields[0]);
    const auto dims = fields[1].cast<std::vector<py::ssize_t>>();
    const bool fortran_order = fields[2].cast<bool>();
    // The strides of a contiguous array of this shape, and its size, checked against the blob.
    std::vector<py::ssize_t> strides(dims.size());
    std::size_t size = static_cast<std::size_t>(dtype.itemsize());
    bool overflow = false;
    for (std::size_t k = 0; k < dims.size() && !overflow; ++k) {
        const std::size_t i = fortran_order ? k : dims.size() - 1 - k;
        strides[i] = static_cast<py::ssize_t>(size);
        overflow = __builtin_mul_overflow(size, static_cast<std::size_t>(dims[i]), &size);
    }
    if (overflow || size != bytes.size() - data_at)
        return {};  // not the array its header says: handed over as bytes
    // The array views the blob's memory; the capsule owns it from now on, and hands it back to
    // libplexus when the array dies, for a later message to be received into memory already mapped
    // (a stream of frames would otherwise pay the kernel to map and zero each one afresh).
    auto* owner = new std::vector<std::uint8_t>(std::move(bytes));
    py::capsule base(owner, [](void* p) {
        auto* buffer = static_cast<std::vector<std::uint8_t>*>(p);
        recycle_blob(std::move(*buffer));
        delete buffer;
    });
    return py::array(dtype, dims, strides, owner->data() + data_at, base);
}

}  // namespace plexus::python
