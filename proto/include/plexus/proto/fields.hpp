#pragma once
// Field-by-field reading and writing of frame bodies. Every length is checked against what is left
// (and against a caller's limit) before anything is allocated or copied.

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {

/// Reads fields from a frame body; the first failure sticks and later reads return nothing.
class FieldReader {
public:
    explicit FieldReader(ByteView body) : rest_(body) {}

    std::optional<std::uint64_t> varint(std::string_view what) {
        if (!failed()) {
            const VarintDecode decoded = decode_varint(rest_);
            if (decoded.status == VarintStatus::ok) {
                rest_ = rest_.subspan(decoded.used);
                return decoded.value;
            }
            fail_varint(what, decoded.status);
        }
        return std::nullopt;
    }
    std::optional<std::uint8_t> byte(std::string_view what);
    /// A varint length then that many bytes; refused if longer than max_size or than what is left.
    std::optional<std::string_view> string(std::string_view what, std::size_t max_size) {
        const auto view = bytes(what, max_size);
        if (!view)
            return std::nullopt;
        return as_string_view(*view);
    }
    std::optional<ByteView> bytes(std::string_view what, std::size_t max_size) {
        const auto length = varint(what);
        if (!length)
            return std::nullopt;
        // The declared length is compared with the limit and with what is left while it is still a
        // 64-bit number: nothing is sized from it until both checks pass.
        if (*length > max_size || *length > rest_.size()) {
            fail_length(what, *length, max_size);
            return std::nullopt;
        }
        const ByteView view = rest_.first(static_cast<std::size_t>(*length));
        rest_ = rest_.subspan(view.size());
        return view;
    }
    /// Exactly n raw bytes.
    std::optional<ByteView> raw(std::string_view what, std::size_t n);
    /// Everything not yet read.
    ByteView rest() const { return rest_; }
    bool failed() const { return error_.has_value(); }
    /// Why the first failing read failed, naming the field ("truncated seq", "source longer than 255").
    const std::string& error() const;

private:
    void fail(std::string message);
    void fail_varint(std::string_view what, VarintStatus status);
    void fail_length(std::string_view what, std::uint64_t length, std::size_t max_size);
    ByteView rest_;
    std::optional<std::string> error_;
};

/// Appends fields to a buffer in the same encoding FieldReader reads.
void append_string(Bytes& out, std::string_view text);
void append_bytes(Bytes& out, ByteView bytes);

}  // namespace plexus::proto
