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
    std::optional<std::string_view> string(std::string_view what, std::size_t max_size);
    std::optional<ByteView> bytes(std::string_view what, std::size_t max_size);
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
    ByteView rest_;
    std::optional<std::string> error_;
};

/// Appends fields to a buffer in the same encoding FieldReader reads.
void append_string(Bytes& out, std::string_view text);
void append_bytes(Bytes& out, ByteView bytes);

}  // namespace plexus::proto
