#include "blob_write.hpp"

#include <cstdint>
#include <mutex>
#include <span>

#include "ndarray.hpp"

namespace py = pybind11;

namespace plexus::python {

namespace {

/// A C-contiguous view of a bytes-like object's buffer, released on destruction (with the GIL,
/// which the caller holds at both ends). While it is held a bytearray cannot be resized.
class BufferView {
public:
    explicit BufferView(py::handle object) {
        if (PyObject_GetBuffer(object.ptr(), &view_, PyBUF_C_CONTIGUOUS) != 0)
            throw py::error_already_set();
    }
    ~BufferView() { PyBuffer_Release(&view_); }
    BufferView(const BufferView&) = delete;
    BufferView& operator=(const BufferView&) = delete;

    std::span<const std::uint8_t> bytes() const {
        return {static_cast<const std::uint8_t*>(view_.buf), static_cast<std::size_t>(view_.len)};
    }

private:
    Py_buffer view_{};
};

void write_without_gil(PythonPort& port, std::span<const std::uint8_t> head,
                       std::span<const std::uint8_t> body, bool flush) {
    // The caller holds the object whose memory this is, so it stays while other threads run; a
    // strict reader may also slow this write down, and they should not wait for it.
    py::gil_scoped_release release;
    std::lock_guard lock(port.write_mutex);
    port.port.write_blob(head, body, flush);
}

}  // namespace

bool write_borrowed_blob(PythonPort& port, py::handle object, bool flush) {
    if (is_ndarray(object)) {
        const NpyParts parts = npy_parts(object);
        write_without_gil(port, parts.head(), parts.body(), flush);
        return true;
    }
    PyObject* o = object.ptr();
    if (PyBytes_Check(o) || PyByteArray_Check(o) || PyMemoryView_Check(o)) {
        const BufferView view(object);
        write_without_gil(port, {}, view.bytes(), flush);
        return true;
    }
    return false;
}

}  // namespace plexus::python
