#include "plexus/proto/cbor.hpp"

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <exception>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace plexus::proto {

namespace {

using nlohmann::json;

// CBOR major types: the top three bits of an item's initial byte.
constexpr std::uint8_t major_unsigned = 0;
constexpr std::uint8_t major_negative = 1;
constexpr std::uint8_t major_bytes = 2;
constexpr std::uint8_t major_text = 3;
constexpr std::uint8_t major_array = 4;
constexpr std::uint8_t major_map = 5;
constexpr std::uint8_t major_tag = 6;
// Major type 7 (floats and simple values) is the default: of each switch on the major type.

// Additional information: the low five bits of the initial byte.
constexpr std::uint8_t info_one_byte = 24;  // 24..27: the argument follows in 1, 2, 4 or 8 bytes
constexpr std::uint8_t info_eight_bytes = 27;
constexpr std::uint8_t info_indefinite = 31;
constexpr std::uint8_t simple_false = 20;
constexpr std::uint8_t simple_true = 21;
constexpr std::uint8_t simple_null = 22;
constexpr std::uint8_t simple_half = 25;
constexpr std::uint8_t simple_single = 26;
constexpr std::uint8_t simple_double = 27;
constexpr std::uint8_t break_byte = 0xff;

// The initial byte of an item and the argument that follows it.
struct Head {
    std::size_t offset = 0;  // of the initial byte
    std::uint8_t initial = 0;
    std::uint8_t major = 0;
    std::uint8_t info = 0;
    std::uint64_t argument = 0;  // the value, length, count, tag number or float bits
    bool indefinite = false;
};

// An array or map still being filled.
struct Frame {
    json* container;
    std::uint64_t remaining;  // elements (arrays) or pairs (maps) still to come; unused if indefinite
    bool indefinite;
    bool map;
};

// The open arrays and maps, innermost last. The first few live inside the object, so a shallow value
// (the usual message) costs no allocation for them; deeper ones spill to the heap.
class FrameStack {
public:
    bool empty() const { return size_ == 0; }
    std::size_t size() const { return size_; }
    Frame& back() { return size_ <= inline_.size() ? inline_[size_ - 1] : heap_.back(); }
    void push(const Frame& frame) {
        if (size_ < inline_.size()) {
            inline_[size_] = frame;
        } else {
            heap_.push_back(frame);
        }
        ++size_;
    }
    void pop() {
        if (size_ > inline_.size()) {
            heap_.pop_back();
        }
        --size_;
    }

private:
    // Left uninitialised on purpose: only slots below size_ are read, and clearing 16 frames
    // would cost a small message more than decoding one of its fields.
    std::array<Frame, 16> inline_;  // NOLINT(cppcoreguidelines-pro-type-member-init)
    std::vector<Frame> heap_;
    std::size_t size_ = 0;
};

std::string hex(std::uint8_t byte) {
    constexpr std::string_view digits = "0123456789abcdef";
    return {'0', 'x', digits[byte >> 4], digits[byte & 0x0f]};
}

std::string kind_of(const Head& head) {
    switch (head.major) {
        case major_unsigned:
            return "unsigned integer";
        case major_negative:
            return "negative integer";
        case major_bytes:
            return "byte string";
        case major_text:
            return "text string";
        case major_array:
            return "array";
        case major_map:
            return "map";
        case major_tag:
            return "tag";
        default:
            return head.info >= simple_half && head.info <= simple_double ? "float" : "simple value";
    }
}

// "an array", "a map": for reasons that read as sentences.
std::string a_kind_of(const Head& head) {
    std::string kind = kind_of(head);
    return (kind.front() == 'a' || kind.front() == 'u' ? "an " : "a ") + kind;
}

// The same conversion as nlohmann's reader (RFC 7049, appendix D), so that both give the same double.
double half_to_double(std::uint64_t half) {
    const auto exponent = static_cast<int>((half >> 10U) & 0x1fU);
    const auto mantissa = static_cast<unsigned int>(half & 0x3ffU);
    double value = 0;
    switch (exponent) {
        case 0:
            value = std::ldexp(mantissa, -24);
            break;
        case 31:
            value = mantissa == 0 ? std::numeric_limits<double>::infinity()
                                  : std::numeric_limits<double>::quiet_NaN();
            break;
        default:
            value = std::ldexp(mantissa + 1024, exponent - 25);
            break;
    }
    return (half & 0x8000U) != 0 ? -value : value;
}

// One pass over the input that builds the value as it goes. Containers are kept on an explicit
// stack rather than the call stack: the depth limit is the caller's choice, and no choice of it
// may let the input overflow the thread's stack.
class Decoder {
public:
    Decoder(ByteView bytes, std::size_t max_depth)
        : data_(bytes.data()), size_(bytes.size()), max_depth_(max_depth) {}

    Result<json> decode() {
        json root;
        if (!read_item(root)) {
            return Error{std::move(error_)};
        }
        while (!stack_.empty()) {
            Frame& frame = stack_.back();
            if (frame.indefinite) {
                if (pos_ == size_) {
                    fail("unexpected end of input at byte " + std::to_string(pos_) + ", inside an " +
                         (frame.map ? "indefinite-length map" : "indefinite-length array") +
                         " that lacks its break (0xff)");
                    return Error{std::move(error_)};
                }
                if (data_[pos_] == break_byte) {
                    ++pos_;
                    stack_.pop();
                    continue;
                }
            } else {
                if (frame.remaining == 0) {
                    stack_.pop();
                    continue;
                }
                --frame.remaining;
                pending_ -= frame.map ? 2 : 1;
            }
            json* slot = nullptr;
            if (frame.map) {
                std::string key;
                if (!read_key(key)) {
                    return Error{std::move(error_)};
                }
                // A repeated key keeps its place and takes the later value, as nlohmann's reader does.
                slot = &frame.container->get_ref<json::object_t&>()[std::move(key)];
            } else {
                slot = &frame.container->get_ref<json::array_t&>().emplace_back();
            }
            // `frame` may dangle from here on: read_item can push onto the stack.
            if (!read_item(*slot)) {
                return Error{std::move(error_)};
            }
        }
        if (pos_ != size_) {
            return Error{std::to_string(size_ - pos_) + " trailing byte(s) after the value, from byte " +
                         std::to_string(pos_)};
        }
        return root;
    }

private:
    bool fail(std::string message) {
        error_ = std::move(message);
        return false;
    }

    std::size_t left() const { return size_ - pos_; }

    // Reads an initial byte and its argument; checks that the argument is all there and that the
    // additional information is not one of the reserved values 28-30. Whether an indefinite length
    // is allowed is up to the caller, which knows the major type.
    bool read_head(Head& head, const char* expected) {
        head.offset = pos_;
        if (pos_ == size_) {
            return fail("unexpected end of input at byte " + std::to_string(pos_) + ", expected " + expected);
        }
        head.initial = data_[pos_++];
        head.major = head.initial >> 5;
        head.info = head.initial & 0x1f;
        head.indefinite = false;
        if (head.info < info_one_byte) {
            head.argument = head.info;
            return true;
        }
        if (head.info == info_indefinite) {
            head.indefinite = true;
            head.argument = 0;
            return true;
        }
        if (head.info > info_eight_bytes) {
            return fail("reserved additional information " + std::to_string(head.info) + " (initial byte " +
                        hex(head.initial) + ") at byte " + std::to_string(head.offset));
        }
        const std::size_t width = std::size_t{1} << (head.info - info_one_byte);
        if (left() < width) {
            return fail("truncated " + kind_of(head) + " at byte " + std::to_string(head.offset) +
                        ": needs " + std::to_string(width) + " byte(s) after the initial byte, " +
                        std::to_string(left()) + " left");
        }
        std::uint64_t argument = 0;
        for (std::size_t i = 0; i < width; ++i) {
            argument = (argument << 8) | data_[pos_ + i];
        }
        pos_ += width;
        head.argument = argument;
        return true;
    }

    bool refuse_indefinite(const Head& head) {
        return fail(a_kind_of(head) + " cannot have an indefinite length (initial byte " + hex(head.initial) +
                    ") at byte " + std::to_string(head.offset));
    }

    // Reads one item into `out`. A non-empty array or map is created empty and pushed on the stack
    // for the loop in decode() to fill.
    bool read_item(json& out) {
        Head head;
        if (!read_head(head, "a value")) {
            return false;
        }
        switch (head.major) {
            case major_unsigned:
                if (head.indefinite) {
                    return refuse_indefinite(head);
                }
                out = static_cast<json::number_unsigned_t>(head.argument);
                return true;
            case major_negative:
                if (head.indefinite) {
                    return refuse_indefinite(head);
                }
                // -1 - n must fit an int64 (nlohmann's number_integer_t); to_cbor never writes less.
                if (head.argument > static_cast<std::uint64_t>(std::numeric_limits<std::int64_t>::max())) {
                    return fail("negative integer -1-" + std::to_string(head.argument) + " at byte " +
                                std::to_string(head.offset) + " is below the 64-bit signed range");
                }
                out = static_cast<json::number_integer_t>(-1 - static_cast<std::int64_t>(head.argument));
                return true;
            case major_bytes: {
                json::binary_t::container_type bytes;
                if (!read_string(head, bytes)) {
                    return false;
                }
                out = json::binary(std::move(bytes));
                return true;
            }
            case major_text: {
                std::string text;
                if (!read_string(head, text)) {
                    return false;
                }
                out = std::move(text);
                return true;
            }
            case major_array:
            case major_map:
                return open_container(head, out);
            case major_tag:
                return read_tagged(head, out);
            default:
                return read_simple(head, out);
        }
    }

    bool read_key(std::string& key) {
        Head head;
        if (!read_head(head, "a map key")) {
            return false;
        }
        if (head.major != major_text) {
            return fail("map key at byte " + std::to_string(head.offset) + " is " + a_kind_of(head) +
                        " (initial byte " + hex(head.initial) + "), not a text string");
        }
        return read_string(head, key);
    }

    // Copies the content of a byte or text string whose head has been read, checking each length
    // against the bytes left before anything is allocated.
    template <typename Container>
    bool read_string(const Head& head, Container& out) {
        if (!head.indefinite) {
            if (!check_length(head)) {
                return false;
            }
            append(out, head.argument);
            return true;
        }
        // Indefinite length: definite-length chunks of the same major type, then a break.
        for (;;) {
            if (pos_ == size_) {
                return fail("unexpected end of input at byte " + std::to_string(pos_) +
                            ", inside the indefinite-length " + kind_of(head) + " at byte " +
                            std::to_string(head.offset));
            }
            if (data_[pos_] == break_byte) {
                ++pos_;
                return true;
            }
            Head chunk;
            if (!read_head(chunk, "a string chunk")) {
                return false;
            }
            if (chunk.major != head.major || chunk.indefinite) {
                return fail("chunk at byte " + std::to_string(chunk.offset) + " (initial byte " +
                            hex(chunk.initial) + ") of the indefinite-length " + kind_of(head) + " at byte " +
                            std::to_string(head.offset) + " is not a definite-length " + kind_of(head));
            }
            if (!check_length(chunk)) {
                return false;
            }
            append(out, chunk.argument);
        }
    }

    bool check_length(const Head& head) {
        if (head.argument > left()) {
            return fail(kind_of(head) + " at byte " + std::to_string(head.offset) + " declares " +
                        std::to_string(head.argument) + " bytes but only " + std::to_string(left()) +
                        " remain");
        }
        return true;
    }

    // One memcpy per string or chunk; `length` has been checked against left().
    void append(std::string& out, std::uint64_t length) {
        const auto* first = reinterpret_cast<const char*>(data_ + pos_);
        out.append(first, static_cast<std::size_t>(length));
        pos_ += static_cast<std::size_t>(length);
    }
    void append(json::binary_t::container_type& out, std::uint64_t length) {
        const std::uint8_t* first = data_ + pos_;
        out.insert(out.end(), first, first + length);
        pos_ += static_cast<std::size_t>(length);
    }

    bool open_container(const Head& head, json& out) {
        if (stack_.size() >= max_depth_) {
            // No offset (it would be head.offset): decode_cbor's tests pin this exact wording.
            return fail("nested deeper than " + std::to_string(max_depth_) + " levels");
        }
        const bool map = head.major == major_map;
        if (head.indefinite) {
            out = map ? json::object() : json::array();
            stack_.push({&out, 0, true, map});
            return true;
        }
        // Every element still owed by an open array or map takes at least one byte of what is left,
        // so a count beyond the rest is refused before anything is reserved, and the reservations of
        // nested arrays together stay within the size of the input.
        const std::size_t room = left() > pending_ ? left() - pending_ : 0;
        const std::uint64_t count = head.argument;
        if (map ? count > room / 2 : count > room) {
            return fail(kind_of(head) + " at byte " + std::to_string(head.offset) + " declares " +
                        std::to_string(count) + (map ? " pairs" : " elements") + " but the " +
                        std::to_string(room) + " byte(s) left for it cannot hold them");
        }
        if (map) {
            out = json::object();
        } else {
            out = json::array();
            out.get_ref<json::array_t&>().reserve(static_cast<std::size_t>(count));
        }
        if (count != 0) {
            stack_.push({&out, count, false, map});
            pending_ += static_cast<std::size_t>(map ? 2 * count : count);
        }
        return true;
    }

    // nlohmann's to_cbor writes a binary value with a subtype as tag 0xd8-0xdb (the subtype in 1, 2,
    // 4 or 8 bytes) followed by the byte string. Other tags have no json equivalent and are refused,
    // as from_cbor does by default.
    bool read_tagged(const Head& head, json& out) {
        if (head.info < info_one_byte || head.indefinite) {
            return fail("unsupported tag (initial byte " + hex(head.initial) + ") at byte " +
                        std::to_string(head.offset) +
                        "; only a binary subtype (0xd8-0xdb) before a byte string is accepted");
        }
        Head inner;
        if (!read_head(inner, "a byte string after a binary subtype tag")) {
            return false;
        }
        if (inner.major != major_bytes) {
            return fail("binary subtype tag at byte " + std::to_string(head.offset) + " is followed by " +
                        a_kind_of(inner) + " (initial byte " + hex(inner.initial) + "), not a byte string");
        }
        json::binary_t::container_type bytes;
        if (!read_string(inner, bytes)) {
            return false;
        }
        out = json::binary(std::move(bytes), head.argument);
        return true;
    }

    bool read_simple(const Head& head, json& out) {
        switch (head.info) {
            case simple_false:
                out = false;
                return true;
            case simple_true:
                out = true;
                return true;
            case simple_null:
                out = nullptr;
                return true;
            case simple_half:
                out = half_to_double(head.argument);
                return true;
            case simple_single:
                out = static_cast<double>(std::bit_cast<float>(static_cast<std::uint32_t>(head.argument)));
                return true;
            case simple_double:
                out = std::bit_cast<double>(head.argument);
                return true;
            case info_indefinite:
                return fail("unexpected break (0xff) at byte " + std::to_string(head.offset));
            default:
                return fail("unsupported simple value (initial byte " + hex(head.initial) + ") at byte " +
                            std::to_string(head.offset));
        }
    }

    const std::uint8_t* data_;
    std::size_t size_;
    std::size_t pos_ = 0;
    std::size_t max_depth_;
    FrameStack stack_;
    std::size_t pending_ = 0;  // elements owed by the open definite-length arrays and maps (pairs count 2)
    std::string error_;
};

}  // namespace

namespace {

/// The payload of a raw stream is one definite-length byte or text string that fills the input:
/// decoded here without the general decoder's machinery. Anything else (or anything wrong) is
/// left to the general decoder, which also words the errors.
std::optional<json> decode_whole_string(ByteView bytes) {
    if (bytes.empty())
        return std::nullopt;
    const std::uint8_t major = bytes[0] >> 5;
    const std::uint8_t info = bytes[0] & 0x1f;
    if ((major != major_bytes && major != major_text) || info > info_eight_bytes)
        return std::nullopt;
    const std::size_t width = info < info_one_byte ? 0 : std::size_t{1} << (info - info_one_byte);
    if (bytes.size() < 1 + width)
        return std::nullopt;
    std::uint64_t length = info < info_one_byte ? info : 0;
    for (std::size_t i = 0; i < width; ++i)
        length = (length << 8) | bytes[1 + i];
    if (length != bytes.size() - 1 - width)
        return std::nullopt;
    const auto content = bytes.subspan(1 + width);
    if (major == major_bytes)
        return json::binary(json::binary_t::container_type(content.begin(), content.end()));
    // Through char pointers: a copy between iterators of different types (uint8_t to char) is an
    // element loop, many times slower than the memcpy this is.
    return json(std::string(reinterpret_cast<const char*>(content.data()), content.size()));
}

}  // namespace

Result<json> decode_cbor_fast(ByteView bytes, std::size_t max_depth) {
    // Every length is checked before it is allocated, so what can still throw is running out of
    // memory for a value the input really holds; a decoder must not throw even then.
    try {
        if (auto whole = decode_whole_string(bytes))
            return std::move(*whole);
        return Decoder(bytes, max_depth).decode();
    } catch (const std::exception& error) {
        return Error{std::string("cannot decode CBOR: ") + error.what()};
    }
}

namespace {

/// A definite-length head: major type and length in the shortest form, as to_cbor writes it.
void append_head(Bytes& out, std::uint8_t major, std::uint64_t length) {
    const auto type = static_cast<std::uint8_t>(major << 5);
    int bytes = 0;
    if (length < 24) {
        out.push_back(static_cast<std::uint8_t>(type | length));
        return;
    }
    if (length <= 0xff) {
        out.push_back(type | 24);
        bytes = 1;
    } else if (length <= 0xffff) {
        out.push_back(type | 25);
        bytes = 2;
    } else if (length <= 0xffffffff) {
        out.push_back(type | 26);
        bytes = 4;
    } else {
        out.push_back(type | 27);
        bytes = 8;
    }
    for (int shift = 8 * (bytes - 1); shift >= 0; shift -= 8)
        out.push_back(static_cast<std::uint8_t>(length >> shift));
}

}  // namespace

void append_byte_string_head(Bytes& out, std::size_t size) {
    append_head(out, 2, size);
}

void encode_cbor(const json& value, Bytes& out) {
    if (value.is_binary() && !value.get_binary().has_subtype()) {
        const auto& bytes = value.get_binary();
        append_head(out, 2, bytes.size());
        out.insert(out.end(), bytes.begin(), bytes.end());
        return;
    }
    if (value.is_string()) {
        const auto& text = value.get_ref<const std::string&>();
        append_head(out, 3, text.size());
        const auto* first = reinterpret_cast<const std::uint8_t*>(text.data());
        out.insert(out.end(), first, first + text.size());  // same element type: one memcpy
        return;
    }
    json::to_cbor(value, out);
}

}  // namespace plexus::proto
