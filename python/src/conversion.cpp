#include "conversion.hpp"

#include <string>

#include "ndarray.hpp"
#include "plexus/proto/control.hpp"

namespace py = pybind11;

namespace plexus::python {

namespace {

// The limit every writer and reader shares (deeper values could be sent but not decoded); it also
// stops a list that contains itself, which would otherwise recurse until the stack runs out.
constexpr int max_depth = static_cast<int>(plexus::proto::max_cbor_depth);

Value blob_from_buffer(py::handle object) {
    Py_buffer view;
    if (PyObject_GetBuffer(object.ptr(), &view, PyBUF_C_CONTIGUOUS) != 0)
        throw py::error_already_set();
    const auto* data = static_cast<const std::uint8_t*>(view.buf);
    Value blob = Value::binary(std::vector<std::uint8_t>(data, data + view.len));
    PyBuffer_Release(&view);
    return blob;
}

Value integer(py::handle object) {
    int overflow = 0;
    const long long value = PyLong_AsLongLongAndOverflow(object.ptr(), &overflow);
    if (overflow == 0) {
        if (value == -1 && PyErr_Occurred())
            throw py::error_already_set();
        return static_cast<std::int64_t>(value);
    }
    if (overflow > 0) {
        const unsigned long long big = PyLong_AsUnsignedLongLong(object.ptr());
        if (!PyErr_Occurred())
            return static_cast<std::uint64_t>(big);
        PyErr_Clear();
    }
    throw py::value_error("integer " + py::str(object).cast<std::string>() +
                          " does not fit in 64 bits (signed or unsigned)");
}

Value convert(py::handle object, int depth) {
    // `depth` containers hold this object; values inside more than max_depth could not be decoded.
    if (depth > max_depth)
        throw py::value_error("the message nests lists and dicts deeper than " + std::to_string(max_depth) +
                              " levels: no reader could decode it");
    PyObject* o = object.ptr();
    if (o == Py_None)
        return nullptr;
    if (PyBool_Check(o))  // before int: bool is an int in Python
        return o == Py_True;
    if (PyLong_Check(o))
        return integer(object);
    if (PyFloat_Check(o))
        return PyFloat_AS_DOUBLE(o);
    if (PyUnicode_Check(o)) {
        Py_ssize_t size = 0;
        const char* text = PyUnicode_AsUTF8AndSize(o, &size);
        if (!text)
            throw py::error_already_set();
        return std::string(text, static_cast<std::size_t>(size));
    }
    if (PyDict_Check(o)) {
        Value map = Value::object();
        PyObject* key = nullptr;
        PyObject* item = nullptr;
        Py_ssize_t at = 0;
        while (PyDict_Next(o, &at, &key, &item)) {
            if (!PyUnicode_Check(key))
                throw py::type_error("map keys must be str, not " + std::string(Py_TYPE(key)->tp_name));
            map[py::reinterpret_borrow<py::str>(key).cast<std::string>()] = convert(item, depth + 1);
        }
        return map;
    }
    if (PyList_Check(o) || PyTuple_Check(o)) {
        py::sequence sequence = py::reinterpret_borrow<py::sequence>(object);
        Value array = Value::array();
        array.get_ref<Value::array_t&>().reserve(sequence.size());
        for (auto item : sequence)
            array.push_back(convert(item, depth + 1));
        return array;
    }
    if (is_ndarray(object))
        return ndarray_to_blob(object);
    if (PyBytes_Check(o) || PyByteArray_Check(o) || PyMemoryView_Check(o))
        return blob_from_buffer(object);
    if (is_numpy_scalar(object))
        return convert(object.attr("item")(), depth);
    throw py::type_error(std::string("cannot send a ") + Py_TYPE(o)->tp_name +
                         ": messages are dict, list, tuple, str, int, float, bool, None, bytes or "
                         "numpy.ndarray");
}

}  // namespace

Value to_value(py::handle object) {
    return convert(object, 0);
}

py::object to_python(Value& value) {
    switch (value.type()) {
        case Value::value_t::null:
            return py::none();
        case Value::value_t::boolean:
            return py::bool_(value.get<bool>());
        case Value::value_t::number_integer:
            return py::int_(value.get<std::int64_t>());
        case Value::value_t::number_unsigned:
            return py::int_(value.get<std::uint64_t>());
        case Value::value_t::number_float:
            return py::float_(value.get<double>());
        case Value::value_t::string: {
            const auto& text = value.get_ref<const std::string&>();
            // "replace", like the CLI's dump: text from elsewhere need not be valid UTF-8.
            PyObject* decoded =
                PyUnicode_DecodeUTF8(text.data(), static_cast<Py_ssize_t>(text.size()), "replace");
            if (!decoded)
                throw py::error_already_set();
            return py::reinterpret_steal<py::object>(decoded);
        }
        case Value::value_t::array: {
            auto& items = value.get_ref<Value::array_t&>();
            py::list list(items.size());
            for (std::size_t i = 0; i < items.size(); ++i)
                list[i] = to_python(items[i]);
            return list;
        }
        case Value::value_t::object: {
            py::dict dict;
            for (auto& [key, item] : value.get_ref<Value::object_t&>())
                dict[py::str(key)] = to_python(item);
            return dict;
        }
        case Value::value_t::binary: {
            auto& bytes = value.get_binary();
            if (py::object array = blob_to_ndarray(bytes))
                return array;
            py::bytes copy(reinterpret_cast<const char*>(bytes.data()), bytes.size());
            recycle_blob(std::move(bytes));  // copied out: a later large blob is received into it
            return copy;
        }
        case Value::value_t::discarded:
            break;
    }
    return py::none();
}

}  // namespace plexus::python
