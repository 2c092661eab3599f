// FrameDecoder on arbitrary bytes, whole and split in two at every byte (nats-server's technique):
// a stream cut anywhere by the network must decode to the same frames, and the answers must keep
// their promises (a frame uses bytes it was given, "need more" asks for more than it was given).
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_check.hpp"
#include "plexus/proto/frame.hpp"

namespace proto = plexus::proto;

namespace {

struct Decoded {
    std::vector<std::pair<proto::FrameType, proto::Bytes>> frames;
    std::vector<std::size_t> sizes;                             ///< bytes each frame took, header included
    proto::DecodeStatus last = proto::DecodeStatus::need_more;  ///< what stopped the decoding
    std::string error;
    bool operator==(const Decoded&) const = default;
};

/// Decodes every frame at the start of `input`; `rest` gets the bytes not yet used.
void decode_all(const proto::FrameDecoder& decoder, proto::ByteView input, Decoded& out, proto::Bytes& rest) {
    std::size_t at = 0;
    while (true) {
        const auto view = input.subspan(at);
        const auto decoded = decoder.decode(view);
        out.last = decoded.status;
        if (decoded.status == proto::DecodeStatus::bad) {
            out.error = decoded.error;
            PLEXUS_FUZZ_CHECK(!decoded.error.empty());
            break;
        }
        if (decoded.status == proto::DecodeStatus::need_more) {
            PLEXUS_FUZZ_CHECK(decoded.needed > view.size());
            break;
        }
        PLEXUS_FUZZ_CHECK(decoded.used > 0 && decoded.used <= view.size());
        PLEXUS_FUZZ_CHECK(decoded.fields.data() >= view.data() &&
                          decoded.fields.data() + decoded.fields.size() <= view.data() + decoded.used);
        PLEXUS_FUZZ_CHECK(decoded.fields.size() < decoder.max_body());
        out.frames.emplace_back(decoded.type, proto::Bytes(decoded.fields.begin(), decoded.fields.end()));
        out.sizes.push_back(decoded.used);
        // Encoding the frame again gives a frame the decoder reads back the same.
        proto::Bytes again;
        proto::append_frame(again, decoded.type, decoded.fields);
        const auto reread = decoder.decode(again);
        PLEXUS_FUZZ_CHECK(reread.status == proto::DecodeStatus::frame && reread.used == again.size());
        PLEXUS_FUZZ_CHECK(reread.type == decoded.type &&
                          proto::Bytes(reread.fields.begin(), reread.fields.end()) ==
                              out.frames.back().second);
        at += decoded.used;
    }
    rest.assign(input.begin() + static_cast<std::ptrdiff_t>(at), input.end());
}

/// Decodes `first`, then what was left of it followed by `second`, as a reader of a socket does.
Decoded decode_in_two(const proto::FrameDecoder& decoder, proto::ByteView first, proto::ByteView second) {
    Decoded out;
    proto::Bytes rest;
    decode_all(decoder, first, out, rest);
    if (out.last == proto::DecodeStatus::bad)
        return out;  // a reader closes the connection here: what follows is never read
    rest.insert(rest.end(), second.begin(), second.end());
    proto::Bytes ignored;
    decode_all(decoder, rest, out, ignored);
    return out;
}

/// Where to cut the input. Every byte for a short input; for a longer one (each cut costs a decode
/// of the whole input, so all of them would make the run quadratic and slow) every byte near the
/// start of a frame, where the length varint and the type are, and 256 cuts spread over the rest.
std::vector<std::size_t> split_points(const Decoded& whole, std::size_t size) {
    std::vector<std::size_t> points;
    if (size <= 512) {
        for (std::size_t split = 0; split <= size; ++split)
            points.push_back(split);
        return points;
    }
    std::size_t start = 0;
    const auto near = [&](std::size_t at) {
        for (std::size_t split = at; split <= std::min(size, at + 12); ++split)
            points.push_back(split);
    };
    // Near the first 64 frames only: an input of a thousand tiny frames would cut 13 000 times.
    for (std::size_t i = 0; i < whole.sizes.size(); ++i) {
        if (i < 64)
            near(start);
        start += whole.sizes[i];
    }
    near(start);
    for (std::size_t i = 0; i <= 256; ++i)
        points.push_back(size * i / 256);
    return points;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const proto::ByteView input(data, size);
    // A small limit as well as the default one, so the "exceeds limit" paths are reached too.
    for (const std::size_t max_body : {proto::default_max_frame, std::size_t{40}}) {
        const proto::FrameDecoder decoder(max_body);
        Decoded whole;
        proto::Bytes rest;
        decode_all(decoder, input, whole, rest);
        for (const std::size_t split : split_points(whole, size)) {
            const auto in_two = decode_in_two(decoder, input.first(split), input.subspan(split));
            PLEXUS_FUZZ_CHECK(in_two == whole);
        }
    }
    for (const auto type : {std::uint8_t{0}, std::uint8_t{4}, std::uint8_t{200}})
        (void)proto::frame_type_name(type);
    return 0;
}
