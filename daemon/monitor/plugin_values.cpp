#include "plugin_values.hpp"

#include <bit>
#include <cmath>
#include <cstring>

#include "plexus/proto/bytes.hpp"

namespace plexus::daemon::monitor::plugin_values {

namespace {

using Byte = unsigned char;

enum : Byte {
    major_unsigned = 0,
    major_negative = 1,
    major_bytes = 2,
    major_text = 3,
    major_array = 4,
    major_map = 5,
    major_tag = 6,
    major_simple = 7,
};
constexpr Byte info_indefinite = 31;
constexpr Byte break_byte = 0xff;

/// The head of one CBOR item: its major type and argument (RFC 8949 3).
struct Head {
    Byte major = 0;
    Byte info = 0;
    std::uint64_t argument = 0;
    bool indefinite = false;
    const Byte* next = nullptr;  ///< first byte after the head
};

bool read_head(const Byte* at, const Byte* end, Head& head) {
    if (at >= end)
        return false;
    head.major = static_cast<Byte>(*at >> 5);
    head.info = static_cast<Byte>(*at & 0x1f);
    ++at;
    head.indefinite = false;
    if (head.info < 24) {
        head.argument = head.info;
    } else if (head.info <= 27) {
        const std::size_t width = std::size_t{1} << (head.info - 24);
        if (static_cast<std::size_t>(end - at) < width)
            return false;
        head.argument = proto::read_big_endian(at, width);
        at += width;
    } else if (head.info == info_indefinite && head.major >= major_bytes && head.major <= major_map) {
        head.indefinite = true;
        head.argument = 0;
    } else if (head.major == major_simple && head.info == info_indefinite) {
        return false;  // a break where an item should be
    } else {
        return false;  // reserved additional information 28-30
    }
    head.next = at;
    return true;
}

/// The end of the item at `at`, or null if it is malformed, truncated or nested too deep.
const Byte* skip(const Byte* at, const Byte* end, std::size_t depth) {
    if (depth > max_depth)
        return nullptr;
    Head head;
    if (!read_head(at, end, head))
        return nullptr;
    const Byte* p = head.next;
    switch (head.major) {
        case major_unsigned:
        case major_negative:
        case major_simple:
            return p;
        case major_bytes:
        case major_text:
            if (head.indefinite) {
                while (p < end && *p != break_byte) {
                    Head chunk;
                    if (!read_head(p, end, chunk) || chunk.major != head.major || chunk.indefinite ||
                        chunk.argument > static_cast<std::uint64_t>(end - chunk.next))
                        return nullptr;
                    p = chunk.next + chunk.argument;
                }
                return p < end ? p + 1 : nullptr;
            }
            if (head.argument > static_cast<std::uint64_t>(end - p))
                return nullptr;
            return p + head.argument;
        case major_array:
        case major_map: {
            const std::uint64_t per_entry = head.major == major_map ? 2 : 1;
            if (head.indefinite) {
                while (p < end && *p != break_byte) {
                    for (std::uint64_t i = 0; i < per_entry && p; ++i)
                        p = skip(p, end, depth + 1);
                    if (!p)
                        return nullptr;
                }
                return p < end ? p + 1 : nullptr;
            }
            // Each item takes at least a byte: a count beyond the bytes left is a lie, refused
            // before looping over it.
            if (head.argument > static_cast<std::uint64_t>(end - p) / per_entry)
                return nullptr;
            for (std::uint64_t i = 0; i < head.argument * per_entry && p; ++i)
                p = skip(p, end, depth + 1);
            return p;
        }
        case major_tag:
            return skip(p, end, depth + 1);
        default:
            return nullptr;
    }
}

/// skip() for the one item at `at`, with the items a message's fields mostly hold (numbers,
/// simple values, short strings) stepped over here and only the rest handed to skip().
inline const Byte* skip_item(const Byte* at, const Byte* end) {
    if (at >= end)
        return nullptr;
    const Byte major = static_cast<Byte>(*at >> 5);
    const Byte info = static_cast<Byte>(*at & 0x1f);
    const auto left = static_cast<std::size_t>(end - at - 1);
    if (major == major_unsigned || major == major_negative || major == major_simple) {
        if (info < 24)
            return at + 1;
        if (info <= 27) {
            const std::size_t width = std::size_t{1} << (info - 24);
            return left >= width ? at + 1 + width : nullptr;
        }
    } else if ((major == major_text || major == major_bytes) && info < 24) {
        return left >= info ? at + 1 + info : nullptr;
    }
    return skip(at, end, 1);
}

const Byte* begin_of(plexus_value value) {
    return value.bytes;
}
const Byte* end_of(plexus_value value) {
    return value.bytes + value.size;
}

/// The head of the value after its tags (nlohmann writes a blob's subtype as a tag).
bool untagged_head(plexus_value value, Head& head) {
    if (!value.bytes)
        return false;
    const Byte* at = begin_of(value);
    for (std::size_t tags = 0; tags <= max_depth; ++tags) {
        if (!read_head(at, end_of(value), head))
            return false;
        if (head.major != major_tag)
            return true;
        at = head.next;
    }
    return false;
}

double half_to_double(std::uint16_t half) {
    const int exponent = (half >> 10) & 0x1f;
    const int mantissa = half & 0x3ff;
    double value = 0;
    if (exponent == 0)
        value = std::ldexp(mantissa, -24);
    else if (exponent == 31)
        value = mantissa == 0 ? INFINITY : NAN;
    else
        value = std::ldexp(mantissa + 1024, exponent - 25);
    return (half & 0x8000) != 0 ? -value : value;
}

constexpr plexus_value absent{nullptr, 0};

/// Calls `visit(item_begin, item_end)` for each item of a definite or indefinite array or map
/// (keys and values alike) until it returns false. False if the container is malformed.
template <typename Visit>
bool each_item(const Head& head, const Byte* end, Visit&& visit) {
    const Byte* p = head.next;
    const std::uint64_t per_entry = head.major == major_map ? 2 : 1;
    const std::uint64_t count = head.indefinite ? UINT64_MAX : head.argument * per_entry;
    if (!head.indefinite && head.argument > static_cast<std::uint64_t>(end - p) / per_entry)
        return false;
    for (std::uint64_t i = 0; i < count; ++i) {
        if (head.indefinite && p < end && *p == break_byte)
            return true;
        const Byte* next = skip(p, end, 1);
        if (!next)
            return false;
        if (!visit(p, next))
            return true;
        p = next;
    }
    return true;
}

}  // namespace

plexus_type type(plexus_value value) {
    if (!value.bytes)
        return PLEXUS_TYPE_ABSENT;
    Head head;
    if (!untagged_head(value, head))
        return PLEXUS_TYPE_INVALID;
    switch (head.major) {
        case major_unsigned:
        case major_negative:
            return PLEXUS_TYPE_INT;
        case major_bytes:
            return PLEXUS_TYPE_BYTES;
        case major_text:
            return PLEXUS_TYPE_STRING;
        case major_array:
            return PLEXUS_TYPE_ARRAY;
        case major_map:
            return PLEXUS_TYPE_MAP;
        default:
            break;
    }
    switch (head.info) {
        case 20:
        case 21:
            return PLEXUS_TYPE_BOOL;
        case 22:
        case 23:
            return PLEXUS_TYPE_NULL;  // undefined reads as null, as nlohmann's from_cbor does
        case 25:
        case 26:
        case 27:
            return PLEXUS_TYPE_FLOAT;
        default:
            return PLEXUS_TYPE_INVALID;
    }
}

int get_bool(plexus_value value, int* out) {
    Head head;
    if (!out || !untagged_head(value, head) || head.major != major_simple ||
        (head.info != 20 && head.info != 21))
        return PLEXUS_MONITOR_ERROR;
    *out = head.info == 21 ? 1 : 0;
    return PLEXUS_MONITOR_OK;
}

int get_int(plexus_value value, std::int64_t* out) {
    Head head;
    if (!out || !untagged_head(value, head))
        return PLEXUS_MONITOR_ERROR;
    if (head.argument > static_cast<std::uint64_t>(INT64_MAX))
        return PLEXUS_MONITOR_ERROR;
    if (head.major == major_unsigned)
        *out = static_cast<std::int64_t>(head.argument);
    else if (head.major == major_negative)
        *out = -1 - static_cast<std::int64_t>(head.argument);
    else
        return PLEXUS_MONITOR_ERROR;
    return PLEXUS_MONITOR_OK;
}

int get_number(plexus_value value, double* out) {
    // A double, as nlohmann writes every non-integral number: read here without the general walk.
    if (out && value.bytes && value.size >= 9 && value.bytes[0] == 0xfb) {
        *out = std::bit_cast<double>(proto::read_big_endian(value.bytes + 1, 8));
        return PLEXUS_MONITOR_OK;
    }
    Head head;
    if (!out || !untagged_head(value, head))
        return PLEXUS_MONITOR_ERROR;
    switch (head.major) {
        case major_unsigned:
            *out = static_cast<double>(head.argument);
            return PLEXUS_MONITOR_OK;
        case major_negative:
            *out = -1.0 - static_cast<double>(head.argument);
            return PLEXUS_MONITOR_OK;
        case major_simple:
            if (head.info == 25) {
                *out = half_to_double(static_cast<std::uint16_t>(head.argument));
                return PLEXUS_MONITOR_OK;
            }
            if (head.info == 26) {
                *out = std::bit_cast<float>(static_cast<std::uint32_t>(head.argument));
                return PLEXUS_MONITOR_OK;
            }
            if (head.info == 27) {
                *out = std::bit_cast<double>(head.argument);
                return PLEXUS_MONITOR_OK;
            }
            return PLEXUS_MONITOR_ERROR;
        default:
            return PLEXUS_MONITOR_ERROR;
    }
}

namespace {
int get_definite(plexus_value value, Byte major, const Byte** data, std::size_t* size) {
    Head head;
    if (!data || !size || !untagged_head(value, head) || head.major != major || head.indefinite ||
        head.argument > static_cast<std::uint64_t>(end_of(value) - head.next))
        return PLEXUS_MONITOR_ERROR;  // an indefinite-length string has no one place to point at
    *data = head.next;
    *size = static_cast<std::size_t>(head.argument);
    return PLEXUS_MONITOR_OK;
}
}  // namespace

int get_string(plexus_value value, const char** data, std::size_t* size) {
    const Byte* bytes = nullptr;
    if (!data || get_definite(value, major_text, &bytes, size) != PLEXUS_MONITOR_OK)
        return PLEXUS_MONITOR_ERROR;
    *data = reinterpret_cast<const char*>(bytes);
    return PLEXUS_MONITOR_OK;
}

int get_bytes(plexus_value value, const unsigned char** data, std::size_t* size) {
    return get_definite(value, major_bytes, data, size);
}

std::size_t length(plexus_value value) {
    Head head;
    if (!untagged_head(value, head) || (head.major != major_array && head.major != major_map))
        return 0;
    if (!head.indefinite)
        return static_cast<std::size_t>(head.argument);
    std::size_t items = 0;
    if (!each_item(head, end_of(value), [&items](const Byte*, const Byte*) { return ++items, true; }))
        return 0;
    return head.major == major_map ? items / 2 : items;
}

plexus_value array_at(plexus_value array, std::size_t index) {
    Head head;
    if (!untagged_head(array, head) || head.major != major_array)
        return absent;
    plexus_value found = absent;
    std::size_t at = 0;
    each_item(head, end_of(array), [&](const Byte* begin, const Byte* end) {
        if (at++ != index)
            return true;
        found = {begin, static_cast<std::size_t>(end - begin)};
        return false;
    });
    return found;
}

plexus_value map_get(plexus_value map, const char* key) {
    Head head;
    if (!key || !untagged_head(map, head) || head.major != major_map)
        return absent;
    if (head.indefinite) {
        // Rare (nlohmann never writes one): the general walk.
        const std::size_t key_size = std::strlen(key);
        plexus_value found = absent;
        bool is_key = true;
        bool matched = false;
        each_item(head, end_of(map), [&](const Byte* begin, const Byte* end) {
            if (!is_key) {
                is_key = true;
                if (!matched)
                    return true;
                found = {begin, static_cast<std::size_t>(end - begin)};
                return false;
            }
            is_key = false;
            Head key_head;
            matched = read_head(begin, end, key_head) && key_head.major == major_text &&
                      !key_head.indefinite && key_head.argument == key_size &&
                      std::memcmp(key_head.next, key, key_size) == 0;
            return true;
        });
        return found;
    }
    // The per-message path (a monitor reading one field): text keys are compared where they lie,
    // only values are skipped; short keys and simple values without the general head reader.
    const Byte* p = head.next;
    const Byte* end = end_of(map);
    const std::size_t key_size = std::strlen(key);
    for (std::uint64_t i = 0; i < head.argument; ++i) {
        if (p >= end)
            return absent;
        bool matched = false;
        if (*p >= 0x60 && *p < 0x60 + 24) {  // a text key shorter than 24 bytes: its head is one byte
            const std::size_t size = *p & 0x1f;
            ++p;
            if (size > static_cast<std::size_t>(end - p))
                return absent;
            matched = size == key_size && std::memcmp(p, key, size) == 0;
            p += size;
        } else {
            Head key_head;
            if (!read_head(p, end, key_head))
                return absent;
            if (key_head.major == major_text && !key_head.indefinite) {
                if (key_head.argument > static_cast<std::uint64_t>(end - key_head.next))
                    return absent;
                matched = key_head.argument == key_size && std::memcmp(key_head.next, key, key_size) == 0;
                p = key_head.next + key_head.argument;
            } else if (!(p = skip(p, end, 1))) {
                return absent;
            }
        }
        const Byte* value_end = skip_item(p, end);
        if (!value_end)
            return absent;
        if (matched)
            return {p, static_cast<std::size_t>(value_end - p)};
        p = value_end;
    }
    return absent;
}

int map_entry(plexus_value map, std::size_t index, plexus_value* key, plexus_value* value) {
    Head head;
    if (!key || !value || !untagged_head(map, head) || head.major != major_map)
        return PLEXUS_MONITOR_ERROR;
    std::size_t at = 0;
    bool found = false;
    each_item(head, end_of(map), [&](const Byte* begin, const Byte* end) {
        const plexus_value item{begin, static_cast<std::size_t>(end - begin)};
        if (at == 2 * index) {
            *key = item;
        } else if (at == 2 * index + 1) {
            *value = item;
            found = true;
            return false;
        }
        ++at;
        return true;
    });
    return found ? PLEXUS_MONITOR_OK : PLEXUS_MONITOR_ERROR;
}

plexus_value first_item(plexus_value value) {
    if (!value.bytes)
        return absent;
    const Byte* end = skip(begin_of(value), end_of(value), 0);
    if (!end)
        return absent;
    return {value.bytes, static_cast<std::size_t>(end - value.bytes)};
}

// --- building ---

namespace {

void fail(plexus_builder* builder, const char* what) {
    if (builder->misuse.empty())
        builder->misuse = what;
}

/// Room for one more item: false (and the builder spoiled) after the top-level value is whole.
bool starting_item(plexus_builder* builder) {
    if (!builder->misuse.empty())
        return false;
    if (builder->complete) {
        fail(builder, "a value was put after the top-level value was complete");
        return false;
    }
    return true;
}

/// One item is whole: it counts against its container, which may so become whole in turn.
void item_done(plexus_builder* builder) {
    while (!builder->open.empty()) {
        if (--builder->open.back() > 0)
            return;
        builder->open.pop_back();
    }
    builder->complete = true;
}

void write_head(plexus_builder* builder, Byte major, std::uint64_t argument) {
    auto& out = builder->bytes;
    const auto initial = static_cast<Byte>(major << 5);
    int width = 0;
    if (argument < 24) {
        out.push_back(static_cast<Byte>(initial | argument));
        return;
    }
    if (argument <= 0xff) {
        out.push_back(initial | 24);
        width = 1;
    } else if (argument <= 0xffff) {
        out.push_back(initial | 25);
        width = 2;
    } else if (argument <= 0xffffffffULL) {
        out.push_back(initial | 26);
        width = 4;
    } else {
        out.push_back(initial | 27);
        width = 8;
    }
    for (int shift = (width - 1) * 8; shift >= 0; shift -= 8)
        out.push_back(static_cast<Byte>(argument >> shift));
}

void begin_container(plexus_builder* builder, Byte major, std::uint64_t items, std::size_t count) {
    if (!starting_item(builder))
        return;
    if (builder->open.size() >= max_depth) {
        fail(builder, "arrays and maps nested deeper than 64");
        return;
    }
    write_head(builder, major, count);
    if (items == 0)
        item_done(builder);
    else
        builder->open.push_back(items);
}

}  // namespace

void reset(plexus_builder* builder) {
    builder->bytes.clear();
    builder->open.clear();
    builder->complete = false;
    builder->misuse.clear();
}

plexus_value value_of(plexus_builder* builder) {
    if (!builder->complete || !builder->misuse.empty())
        return absent;
    return {builder->bytes.data(), builder->bytes.size()};
}

std::string problem_of(const plexus_builder& builder) {
    if (!builder.misuse.empty())
        return builder.misuse;
    if (builder.bytes.empty())
        return "nothing was built";
    if (!builder.complete)
        return "an array or map is missing " + std::to_string(builder.open.back()) + " item(s)";
    return "";
}

void put_null(plexus_builder* builder) {
    if (!starting_item(builder))
        return;
    builder->bytes.push_back(0xf6);
    item_done(builder);
}

void put_bool(plexus_builder* builder, int value) {
    if (!starting_item(builder))
        return;
    builder->bytes.push_back(value ? 0xf5 : 0xf4);
    item_done(builder);
}

void put_int(plexus_builder* builder, std::int64_t value) {
    if (!starting_item(builder))
        return;
    if (value >= 0)
        write_head(builder, major_unsigned, static_cast<std::uint64_t>(value));
    else
        write_head(builder, major_negative, static_cast<std::uint64_t>(-1 - value));
    item_done(builder);
}

void put_float(plexus_builder* builder, double value) {
    if (!starting_item(builder))
        return;
    builder->bytes.push_back(0xfb);
    const auto bits = std::bit_cast<std::uint64_t>(value);
    for (int shift = 56; shift >= 0; shift -= 8)
        builder->bytes.push_back(static_cast<Byte>(bits >> shift));
    item_done(builder);
}

void put_string(plexus_builder* builder, const char* data, std::size_t size) {
    if (!starting_item(builder))
        return;
    if (!data && size > 0) {
        fail(builder, "put_string of a null pointer");
        return;
    }
    write_head(builder, major_text, size);
    builder->bytes.insert(builder->bytes.end(), data, data + size);
    item_done(builder);
}

void put_bytes(plexus_builder* builder, const void* data, std::size_t size) {
    if (!starting_item(builder))
        return;
    if (!data && size > 0) {
        fail(builder, "put_bytes of a null pointer");
        return;
    }
    write_head(builder, major_bytes, size);
    const auto* bytes = static_cast<const Byte*>(data);
    builder->bytes.insert(builder->bytes.end(), bytes, bytes + size);
    item_done(builder);
}

void begin_array(plexus_builder* builder, std::size_t count) {
    begin_container(builder, major_array, count, count);
}

void begin_map(plexus_builder* builder, std::size_t count) {
    begin_container(builder, major_map, 2 * static_cast<std::uint64_t>(count), count);
}

void put_value(plexus_builder* builder, plexus_value value) {
    if (!starting_item(builder))
        return;
    const plexus_value item = first_item(value);
    if (!item.bytes) {
        fail(builder, "put_value of an absent or malformed value");
        return;
    }
    builder->bytes.insert(builder->bytes.end(), item.bytes, item.bytes + item.size);
    item_done(builder);
}

}  // namespace plexus::daemon::monitor::plugin_values
