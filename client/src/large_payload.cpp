#include "large_payload.hpp"

#include "plexus/proto/frame.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::detail {

namespace {

constexpr std::uint8_t cbor_major_bytes = 2;

/// Reads the fields at the front of a frame one by one; any shortfall fails the whole parse.
class PrefixReader {
public:
    explicit PrefixReader(proto::ByteView bytes) : bytes_(bytes) {}

    std::optional<std::uint64_t> varint() {
        const auto decoded = proto::decode_varint(bytes_.subspan(at_));
        if (decoded.status != proto::VarintStatus::ok)
            return std::nullopt;
        at_ += decoded.used;
        return decoded.value;
    }
    std::optional<std::uint8_t> byte() {
        if (at_ >= bytes_.size())
            return std::nullopt;
        return bytes_[at_++];
    }
    std::optional<proto::ByteView> take(std::size_t n) {
        if (n > bytes_.size() - at_)
            return std::nullopt;
        const auto view = bytes_.subspan(at_, n);
        at_ += n;
        return view;
    }
    std::size_t offset() const { return at_; }

private:
    proto::ByteView bytes_;
    std::size_t at_ = 0;
};

}  // namespace

std::optional<ByteStringHead> parse_byte_string_head(proto::ByteView bytes) {
    PrefixReader reader(bytes);
    const auto initial = reader.byte();
    if (!initial || (*initial >> 5) != cbor_major_bytes)
        return std::nullopt;
    // The length: the initial byte's low 5 bits, or 1, 2, 4 or 8 bytes after it.
    const std::uint8_t info = *initial & 0x1f;
    std::uint64_t length = info;
    if (info >= 24) {
        if (info > 27)
            return std::nullopt;  // indefinite length (chunks) or reserved: the ordinary path
        const auto width = std::size_t{1} << (info - 24);
        const auto bytes_of_length = reader.take(width);
        if (!bytes_of_length)
            return std::nullopt;
        length = 0;
        for (const auto b : *bytes_of_length)
            length = (length << 8) | b;
    }
    return ByteStringHead{length, reader.offset()};
}

std::optional<LargePayloadFrame> parse_large_payload_frame(proto::ByteView start, std::size_t frame_size) {
    if (frame_size < large_payload_frame)
        return std::nullopt;
    PrefixReader reader(start.first(std::min(start.size(), frame_size)));
    const auto body = reader.varint();
    const auto type = reader.byte();
    if (!body || !type || *type != static_cast<std::uint8_t>(proto::FrameType::data) ||
        reader.offset() - 1 + *body != frame_size)
        return std::nullopt;
    LargePayloadFrame frame;
    const auto handle = reader.varint();
    const auto source_size = reader.varint();
    if (!handle || !source_size || *source_size > proto::max_port_name)
        return std::nullopt;
    const auto source = reader.take(static_cast<std::size_t>(*source_size));
    const auto seq = reader.varint();
    const auto time_ns = reader.varint();
    if (!source || !seq || !time_ns)
        return std::nullopt;
    const auto string_head = parse_byte_string_head(start.subspan(std::min(start.size(), reader.offset())));
    if (!string_head || !reader.take(string_head->head_size))
        return std::nullopt;
    const std::uint64_t length = string_head->length;
    if (length != frame_size - reader.offset())
        return std::nullopt;  // not one byte string running to the frame's end
    frame.handle = *handle;
    frame.envelope =
        Envelope{std::string(reinterpret_cast<const char*>(source->data()), source->size()), *seq, *time_ns};
    frame.payload_offset = reader.offset();
    frame.payload_size = static_cast<std::size_t>(length);
    return frame;
}

}  // namespace plexus::detail
