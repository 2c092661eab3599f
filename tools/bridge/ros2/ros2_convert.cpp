#include "ros2_convert.hpp"

#include <cmath>
#include <cstring>
#include <limits>

namespace plexus::bridge::ros2 {

namespace {

template <class T>
T load(const char* at) {
    T value;
    std::memcpy(&value, at, sizeof value);
    return value;
}

template <class T>
void store(char* at, T value) {
    std::memcpy(at, &value, sizeof value);
}

const char* kind_of(const Value& value) {
    switch (value.type()) {
        case Value::value_t::null:
            return "null";
        case Value::value_t::boolean:
            return "true or false";
        case Value::value_t::string:
            return "a text";
        case Value::value_t::array:
            return "a list";
        case Value::value_t::object:
            return "a map";
        case Value::value_t::binary:
            return "a blob";
        default:
            return "a number";
    }
}

std::string expected(const std::string& path, const char* what, const Value& value) {
    return path + ": expected " + what + ", not " + kind_of(value);
}

Value sequence_value(const Field& field, const char* at) {
    const auto sequence = load<Sequence>(at);
    const auto* buffer = static_cast<const char*>(sequence.buffer);
    switch (field.kind) {
        case FieldKind::octets: {
            const auto* first = reinterpret_cast<const std::uint8_t*>(buffer);
            return Value::binary(std::vector<std::uint8_t>(first, first + sequence.length));
        }
        case FieldKind::float32s: {
            Value list = Value::array();
            for (std::uint32_t i = 0; i < sequence.length; ++i)
                list.push_back(load<float>(buffer + i * sizeof(float)));
            return list;
        }
        case FieldKind::float64s: {
            Value list = Value::array();
            for (std::uint32_t i = 0; i < sequence.length; ++i)
                list.push_back(load<double>(buffer + i * sizeof(double)));
            return list;
        }
        case FieldKind::strings: {
            Value list = Value::array();
            for (std::uint32_t i = 0; i < sequence.length; ++i) {
                const char* text = load<const char*>(buffer + i * sizeof(char*));
                list.push_back(text ? text : "");
            }
            return list;
        }
        default: {  // structures
            Value list = Value::array();
            for (std::uint32_t i = 0; i < sequence.length; ++i)
                list.push_back(to_value(buffer + i * field.nested->size, *field.nested));
            return list;
        }
    }
}

Value field_value(const Field& field, const char* base) {
    const char* at = base + field.offset;
    switch (field.kind) {
        case FieldKind::boolean:
            return load<bool>(at);
        case FieldKind::octet:
            return load<std::uint8_t>(at);
        case FieldKind::int32:
            return load<std::int32_t>(at);
        case FieldKind::uint32:
            return load<std::uint32_t>(at);
        case FieldKind::int64:
            return load<std::int64_t>(at);
        case FieldKind::float32:
            return load<float>(at);
        case FieldKind::float64:
            return load<double>(at);
        case FieldKind::string: {
            const char* text = load<const char*>(at);
            return text ? text : "";
        }
        case FieldKind::structure:
            return to_value(at, *field.nested);
        case FieldKind::float64_array: {
            Value list = Value::array();
            for (std::size_t i = 0; i < field.count; ++i)
                list.push_back(load<double>(at + i * sizeof(double)));
            return list;
        }
        default:
            return sequence_value(field, at);
    }
}

/// A whole number in [low, high], or an error.
template <class T>
std::string whole_into(const Value& value, const std::string& path, char* at) {
    constexpr auto low = std::numeric_limits<T>::min();
    constexpr auto high = std::numeric_limits<T>::max();
    if (value.is_number_unsigned()) {
        const auto v = value.get<std::uint64_t>();
        if (v > static_cast<std::uint64_t>(high))
            return path + ": " + std::to_string(v) + " does not fit";
        store<T>(at, static_cast<T>(v));
        return "";
    }
    if (value.is_number_integer()) {
        const auto v = value.get<std::int64_t>();
        if ((std::is_unsigned_v<T> && v < 0) ||
            (!std::is_unsigned_v<T> && v < static_cast<std::int64_t>(low)) ||
            (v > 0 && static_cast<std::uint64_t>(v) > static_cast<std::uint64_t>(high)))
            return path + ": " + std::to_string(v) + " does not fit";
        store<T>(at, static_cast<T>(v));
        return "";
    }
    if (value.is_boolean() && std::is_same_v<T, std::uint8_t>) {
        store<T>(at, value.get<bool>() ? 1 : 0);
        return "";
    }
    return expected(path, "a whole number", value);
}

template <class T>
std::string number_into(const Value& value, const std::string& path, char* at) {
    if (!value.is_number())
        return expected(path, "a number", value);
    store<T>(at, value.get<T>());
    return "";
}

}  // namespace

Value to_value(const void* sample, const StructLayout& layout) {
    Value map = Value::object();
    const auto* base = static_cast<const char*>(sample);
    for (const auto& field : layout.fields)
        map[field.name] = field_value(field, base);
    return map;
}

std::string SampleBuilder::fill(const Value& value, const StructLayout& layout, void* sample) {
    std::memset(sample, 0, layout.size);
    return fill_struct(value, layout, static_cast<char*>(sample), "");
}

void SampleBuilder::clear() {
    texts_.clear();
    blocks_.clear();
}

char* SampleBuilder::text(const std::string& value) {
    return texts_.emplace_back(value).data();
}

void* SampleBuilder::bytes(std::size_t size) {
    return blocks_.emplace_back(size).data();
}

std::string SampleBuilder::fill_struct(const Value& value, const StructLayout& layout, char* at,
                                       const std::string& path) {
    const std::string where = path.empty() ? std::string(layout.name) : path.substr(0, path.size() - 1);
    // Defaults first (zero is memset), then what the map gives.
    for (const auto& field : layout.fields) {
        if (field.kind == FieldKind::string)
            store<char*>(at + field.offset, text(""));
        else if (field.kind == FieldKind::structure)
            fill_struct(Value::object(), *field.nested, at + field.offset, path + field.name + ".");
        else if (field.default_value != 0)
            store<double>(at + field.offset, field.default_value);
    }
    if (!value.is_object())
        return expected(where, "a map", value);
    for (const auto& [key, entry] : value.items()) {
        const Field* field = nullptr;
        for (const auto& candidate : layout.fields) {
            if (key == candidate.name)
                field = &candidate;
        }
        if (!field)
            return path + key + ": " + layout.name + " has no such field";
        if (auto error = fill_field(entry, *field, at + field->offset, path + key); !error.empty())
            return error;
    }
    return "";
}

std::string SampleBuilder::fill_field(const Value& value, const Field& field, char* at,
                                      const std::string& path) {
    switch (field.kind) {
        case FieldKind::boolean:
            if (!value.is_boolean())
                return expected(path, "true or false", value);
            store<bool>(at, value.get<bool>());
            return "";
        case FieldKind::octet:
            return whole_into<std::uint8_t>(value, path, at);
        case FieldKind::int32:
            return whole_into<std::int32_t>(value, path, at);
        case FieldKind::uint32:
            return whole_into<std::uint32_t>(value, path, at);
        case FieldKind::int64:
            return whole_into<std::int64_t>(value, path, at);
        case FieldKind::float32:
            return number_into<float>(value, path, at);
        case FieldKind::float64:
            return number_into<double>(value, path, at);
        case FieldKind::string:
            if (!value.is_string())
                return expected(path, "a text", value);
            store<char*>(at, text(value.get_ref<const std::string&>()));
            return "";
        case FieldKind::structure:
            return fill_struct(value, *field.nested, at, path + ".");
        case FieldKind::float64_array: {
            if (!value.is_array() || value.size() != field.count)
                return expected(path, ("a list of " + std::to_string(field.count) + " numbers").c_str(),
                                value);
            for (std::size_t i = 0; i < field.count; ++i) {
                if (auto error = number_into<double>(value[i], path + "[" + std::to_string(i) + "]",
                                                     at + i * sizeof(double));
                    !error.empty())
                    return error;
            }
            return "";
        }
        default:
            break;
    }
    // Sequences: the sample points at the value's own bytes (a blob) or at storage of the builder.
    Sequence sequence{0, 0, nullptr, false};
    if (field.kind == FieldKind::octets && value.is_binary()) {
        const auto& blob = value.get_binary();
        if (blob.size() > std::numeric_limits<std::uint32_t>::max())
            return path + ": a blob of more than 4 GiB";
        sequence.length = sequence.maximum = static_cast<std::uint32_t>(blob.size());
        sequence.buffer = const_cast<std::uint8_t*>(blob.data());
        store<Sequence>(at, sequence);
        return "";
    }
    if (!value.is_array())
        return expected(path, field.kind == FieldKind::octets ? "a blob or a list of bytes" : "a list",
                        value);
    std::size_t element = 0;
    switch (field.kind) {
        case FieldKind::octets:
            element = 1;
            break;
        case FieldKind::float32s:
            element = sizeof(float);
            break;
        case FieldKind::float64s:
            element = sizeof(double);
            break;
        case FieldKind::strings:
            element = sizeof(char*);
            break;
        default:
            element = field.nested->size;
            break;
    }
    sequence.length = sequence.maximum = static_cast<std::uint32_t>(value.size());
    auto* buffer = static_cast<char*>(bytes(element * value.size() + 1));
    std::memset(buffer, 0, element * value.size());
    sequence.buffer = buffer;
    for (std::size_t i = 0; i < value.size(); ++i) {
        const std::string item = path + "[" + std::to_string(i) + "]";
        char* slot = buffer + i * element;
        std::string error;
        switch (field.kind) {
            case FieldKind::octets:
                error = whole_into<std::uint8_t>(value[i], item, slot);
                break;
            case FieldKind::float32s:
                error = number_into<float>(value[i], item, slot);
                break;
            case FieldKind::float64s:
                error = number_into<double>(value[i], item, slot);
                break;
            case FieldKind::strings:
                if (!value[i].is_string())
                    error = expected(item, "a text", value[i]);
                else
                    store<char*>(slot, text(value[i].get_ref<const std::string&>()));
                break;
            default:
                error = fill_struct(value[i], *field.nested, slot, item + ".");
                break;
        }
        if (!error.empty())
            return error;
    }
    store<Sequence>(at, sequence);
    return "";
}

}  // namespace plexus::bridge::ros2
