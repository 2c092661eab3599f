#include "encoding.hpp"

namespace plexus::mcap {

namespace {

template <typename T>
void put_little_endian(proto::Bytes& out, T value) {
    for (std::size_t i = 0; i < sizeof(T); ++i)
        out.push_back(static_cast<std::uint8_t>(static_cast<std::uint64_t>(value) >> (8 * i)));
}

template <typename T>
T load_little_endian(const std::uint8_t* at) {
    std::uint64_t value = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i)
        value |= std::uint64_t{at[i]} << (8 * i);
    return static_cast<T>(value);
}

}  // namespace

void put_u8(proto::Bytes& out, std::uint8_t value) {
    out.push_back(value);
}
void put_u16(proto::Bytes& out, std::uint16_t value) {
    put_little_endian(out, value);
}
void put_u32(proto::Bytes& out, std::uint32_t value) {
    put_little_endian(out, value);
}
void put_u64(proto::Bytes& out, std::uint64_t value) {
    put_little_endian(out, value);
}

void put_string(proto::Bytes& out, std::string_view text) {
    put_u32(out, static_cast<std::uint32_t>(text.size()));
    out.insert(out.end(), text.begin(), text.end());
}

void put_string_map(proto::Bytes& out, const StringMap& map) {
    std::uint64_t size = 0;
    for (const auto& [key, value] : map)
        size += 8 + key.size() + value.size();
    put_u32(out, static_cast<std::uint32_t>(size));
    for (const auto& [key, value] : map) {
        put_string(out, key);
        put_string(out, value);
    }
}

std::size_t begin_record(proto::Bytes& out, format::Opcode opcode) {
    put_u8(out, static_cast<std::uint8_t>(opcode));
    put_u64(out, 0);
    return out.size();
}

void end_record(proto::Bytes& out, std::size_t content_start) {
    const std::uint64_t length = out.size() - content_start;
    for (std::size_t i = 0; i < 8; ++i)
        out[content_start - 8 + i] = static_cast<std::uint8_t>(length >> (8 * i));
}

std::uint64_t load_u64(const std::uint8_t* at) {
    return load_little_endian<std::uint64_t>(at);
}

const std::uint8_t* FieldReader::take(std::uint64_t size, std::string_view field) {
    if (!ok())
        return nullptr;
    if (size > content_.size() - at_) {
        error_ = where_ + ": its " + std::string(field) + " runs past the end of the record";
        return nullptr;
    }
    const std::uint8_t* start = content_.data() + at_;
    at_ += size;
    return start;
}

proto::ByteView FieldReader::sized(std::uint64_t size, std::string_view field) {
    const std::uint8_t* start = take(size, field);
    return start == nullptr ? proto::ByteView{} : proto::ByteView(start, size);
}

std::uint8_t FieldReader::u8(std::string_view field) {
    const auto* at = take(1, field);
    return at == nullptr ? 0 : *at;
}
std::uint16_t FieldReader::u16(std::string_view field) {
    const auto* at = take(2, field);
    return at == nullptr ? 0 : load_little_endian<std::uint16_t>(at);
}
std::uint32_t FieldReader::u32(std::string_view field) {
    const auto* at = take(4, field);
    return at == nullptr ? 0 : load_little_endian<std::uint32_t>(at);
}
std::uint64_t FieldReader::u64(std::string_view field) {
    const auto* at = take(8, field);
    return at == nullptr ? 0 : load_little_endian<std::uint64_t>(at);
}

std::string FieldReader::string(std::string_view field) {
    return std::string(proto::as_string_view(bytes32(field)));
}

proto::ByteView FieldReader::bytes32(std::string_view field) {
    const std::uint32_t size = u32(field);
    return sized(size, field);
}

proto::ByteView FieldReader::bytes64(std::string_view field) {
    const std::uint64_t size = u64(field);
    return sized(size, field);
}

StringMap FieldReader::string_map(std::string_view field) {
    StringMap map;
    FieldReader entries(bytes32(field), where_);
    while (ok() && !entries.rest().empty()) {
        std::string key = entries.string(field);
        std::string value = entries.string(field);
        if (!entries.ok()) {
            error_ = entries.error_;
            break;
        }
        map.insert_or_assign(std::move(key), std::move(value));
    }
    return ok() ? map : StringMap{};
}

std::map<std::uint16_t, std::uint64_t> FieldReader::u16_u64_map(std::string_view field) {
    std::map<std::uint16_t, std::uint64_t> map;
    FieldReader entries(bytes32(field), where_);
    while (ok() && !entries.rest().empty()) {
        const std::uint16_t key = entries.u16(field);
        const std::uint64_t value = entries.u64(field);
        if (!entries.ok()) {
            error_ = entries.error_;
            break;
        }
        map.insert_or_assign(key, value);
    }
    return ok() ? map : std::map<std::uint16_t, std::uint64_t>{};
}

}  // namespace plexus::mcap
