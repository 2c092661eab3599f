#include "plexus/proto/fields.hpp"

#include "plexus/proto/varint.hpp"

namespace plexus::proto {

namespace {

std::string describe_length(std::string_view what, std::uint64_t length, std::size_t max_size) {
    return std::string(what) + " longer than " + std::to_string(max_size) + " bytes (" +
           std::to_string(length) + ")";
}

}  // namespace

void FieldReader::fail_varint(std::string_view what, VarintStatus status) {
    if (status == VarintStatus::need_more)
        fail("truncated " + std::string(what));
    else
        fail(std::string(what) + " is not a valid varint (longer than 10 bytes or over 64 bits)");
}

std::optional<std::uint8_t> FieldReader::byte(std::string_view what) {
    const auto view = raw(what, 1);
    if (!view) {
        return std::nullopt;
    }
    return (*view)[0];
}

void FieldReader::fail_length(std::string_view what, std::uint64_t length, std::size_t max_size) {
    if (length > max_size) {
        fail(describe_length(what, length, max_size));
    } else {
        fail("truncated " + std::string(what) + " (declares " + std::to_string(length) + " bytes, " +
             std::to_string(rest_.size()) + " left)");
    }
}

std::optional<ByteView> FieldReader::raw(std::string_view what, std::size_t n) {
    if (failed()) {
        return std::nullopt;
    }
    if (n > rest_.size()) {
        fail("truncated " + std::string(what));
        return std::nullopt;
    }
    const ByteView view = rest_.first(n);
    rest_ = rest_.subspan(n);
    return view;
}

const std::string& FieldReader::error() const {
    static const std::string none;
    return error_ ? *error_ : none;
}

void FieldReader::fail(std::string message) {
    if (!error_) {
        error_ = std::move(message);
    }
    rest_ = {};
}

void append_string(Bytes& out, std::string_view text) {
    append_bytes(out, as_bytes(text));
}

void append_bytes(Bytes& out, ByteView bytes) {
    append_varint(out, bytes.size());
    out.insert(out.end(), bytes.begin(), bytes.end());
}

}  // namespace plexus::proto
