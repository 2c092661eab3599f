#pragma once
// Little-endian fields in and out of record contents (the layout is in format.hpp). Writing
// appends to a byte vector; reading goes through FieldReader, which checks each field against
// the bytes left and remembers the first one that did not fit.

#include <cstdint>
#include <string>
#include <string_view>

#include "format.hpp"
#include "plexus/mcap/records.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::mcap {

void put_u8(proto::Bytes& out, std::uint8_t value);
void put_u16(proto::Bytes& out, std::uint16_t value);
void put_u32(proto::Bytes& out, std::uint32_t value);
void put_u64(proto::Bytes& out, std::uint64_t value);
/// u32 length and the bytes.
void put_string(proto::Bytes& out, std::string_view text);
/// u32 byte length and key/value strings (std::map: sorted, unique keys).
void put_string_map(proto::Bytes& out, const StringMap& map);

/// Starts a record: writes the opcode and a length to be patched; returns where the content starts.
std::size_t begin_record(proto::Bytes& out, format::Opcode opcode);
/// Patches the length of the record whose content started at `content_start`.
void end_record(proto::Bytes& out, std::size_t content_start);

/// Little-endian at `at` (8 bytes).
std::uint64_t load_u64(const std::uint8_t* at);

/// Reads the fields of one record's content in order. A field that does not fit makes this and
/// every later read return zero/empty; error() then names the first such field.
class FieldReader {
public:
    /// `where` prefixes errors, e.g. "offset 1234: channel record".
    FieldReader(proto::ByteView content, std::string where) : content_(content), where_(std::move(where)) {}

    std::uint8_t u8(std::string_view field);
    std::uint16_t u16(std::string_view field);
    std::uint32_t u32(std::string_view field);
    std::uint64_t u64(std::string_view field);
    std::string string(std::string_view field);
    /// u32 length-prefixed bytes, as a view into the content.
    proto::ByteView bytes32(std::string_view field);
    /// u64 length-prefixed bytes, as a view into the content.
    proto::ByteView bytes64(std::string_view field);
    StringMap string_map(std::string_view field);
    /// u32 byte length, then (u16, u64) pairs.
    std::map<std::uint16_t, std::uint64_t> u16_u64_map(std::string_view field);
    /// The bytes not read yet.
    proto::ByteView rest() const { return content_.subspan(at_); }

    bool ok() const { return error_.empty(); }
    /// "offset 1234: channel record: its topic runs past the end of the record".
    proto::Error error() const { return {error_}; }

private:
    /// The next `size` bytes, or an empty view and a recorded error.
    const std::uint8_t* take(std::uint64_t size, std::string_view field);
    proto::ByteView sized(std::uint64_t size, std::string_view field);

    proto::ByteView content_;
    std::size_t at_ = 0;
    std::string where_;
    std::string error_;
};

}  // namespace plexus::mcap
