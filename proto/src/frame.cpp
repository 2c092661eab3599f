#include "plexus/proto/frame.hpp"

#include <limits>

#include "plexus/proto/fields.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {

namespace {

bool is_known_type(std::uint8_t type) {
    return type >= static_cast<std::uint8_t>(FrameType::hello) &&
           type <= static_cast<std::uint8_t>(FrameType::rings);
}

FrameDecode need_more(std::size_t needed) {
    return {DecodeStatus::need_more, {}, {}, 0, needed, {}};
}

FrameDecode bad(std::string error) {
    return {DecodeStatus::bad, {}, {}, 0, 0, std::move(error)};
}

// Cuts `text` to at most `limit` bytes without splitting a UTF-8 sequence.
std::string_view cut_utf8(std::string_view text, std::size_t limit) {
    if (text.size() <= limit) {
        return text;
    }
    std::size_t end = limit;
    while (end > 0 && (static_cast<unsigned char>(text[end]) & 0xc0) == 0x80) {
        --end;
    }
    return text.substr(0, end);
}

}  // namespace

FrameDecode FrameDecoder::decode(ByteView input) const {
    const VarintDecode header = decode_varint(input);
    if (header.status == VarintStatus::need_more) {
        return need_more(input.size() + 1);
    }
    if (header.status == VarintStatus::bad) {
        return bad("bad frame length: varint longer than 10 bytes or over 64 bits");
    }
    const std::uint64_t length = header.value;
    // The length is judged while it is still a 64-bit number, before anyone sizes a buffer from it.
    if (length > max_body_ || length > std::numeric_limits<std::size_t>::max() - header.used) {
        return bad("frame length " + std::to_string(length) + " exceeds limit " + std::to_string(max_body_));
    }
    if (length == 0) {
        return bad("frame length 0: a frame holds at least its type byte");
    }
    const auto body_size = static_cast<std::size_t>(length);
    const ByteView after_header = input.subspan(header.used);
    // The type byte is judged as soon as it arrives, so a stray stream is refused without
    // waiting for a body that may never come.
    if (!after_header.empty() && !is_known_type(after_header[0])) {
        return bad("unknown frame type " + std::to_string(after_header[0]));
    }
    if (!after_header.empty() && after_header[0] == static_cast<std::uint8_t>(FrameType::request) &&
        length > max_request_frame) {
        return bad("request frame length " + std::to_string(length) + " exceeds limit " +
                   std::to_string(max_request_frame));
    }
    if (after_header.size() < body_size) {
        return need_more(header.used + body_size);
    }
    return {DecodeStatus::frame,
            static_cast<FrameType>(after_header[0]),
            after_header.subspan(1, body_size - 1),
            header.used + body_size,
            0,
            {}};
}

void append_frame_header(Bytes& out, FrameType type, std::size_t fields_size) {
    append_varint(out, static_cast<std::uint64_t>(fields_size) + 1);
    out.push_back(static_cast<std::uint8_t>(type));
}

void append_frame(Bytes& out, FrameType type, ByteView fields) {
    append_frame_header(out, type, fields.size());
    out.insert(out.end(), fields.begin(), fields.end());
}

Bytes make_error_frame(std::string_view reason) {
    const std::string_view text = cut_utf8(reason, max_error_reason);
    Bytes fields;
    append_string(fields, text);
    Bytes out;
    append_frame(out, FrameType::error, fields);
    return out;
}

Result<std::string> decode_error(ByteView fields) {
    FieldReader reader(fields);
    const auto reason = reader.string("error reason", max_error_reason);
    if (!reason) {
        return Error{reader.error()};
    }
    // Bytes after the reason are ignored: the connection is closing and the reason is what matters.
    return std::string(*reason);
}

std::string frame_type_name(std::uint8_t type) {
    switch (type) {
        case static_cast<std::uint8_t>(FrameType::hello):
            return "hello";
        case static_cast<std::uint8_t>(FrameType::request):
            return "request";
        case static_cast<std::uint8_t>(FrameType::reply):
            return "reply";
        case static_cast<std::uint8_t>(FrameType::data):
            return "data";
        case static_cast<std::uint8_t>(FrameType::error):
            return "error";
        case static_cast<std::uint8_t>(FrameType::data_batch):
            return "data_batch";
        case static_cast<std::uint8_t>(FrameType::data_shm):
            return "data_shm";
        case static_cast<std::uint8_t>(FrameType::shm_region):
            return "shm_region";
        case static_cast<std::uint8_t>(FrameType::shm_release):
            return "shm_release";
        case static_cast<std::uint8_t>(FrameType::shm_free):
            return "shm_free";
        case static_cast<std::uint8_t>(FrameType::shm_region_gone):
            return "shm_region_gone";
        case static_cast<std::uint8_t>(FrameType::auth):
            return "auth";
        case static_cast<std::uint8_t>(FrameType::call):
            return "call";
        case static_cast<std::uint8_t>(FrameType::answer):
            return "answer";
        case static_cast<std::uint8_t>(FrameType::rings):
            return "rings";
        default:
            return "unknown(" + std::to_string(type) + ")";
    }
}

}  // namespace plexus::proto
