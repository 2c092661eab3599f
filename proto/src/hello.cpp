#include "plexus/proto/hello.hpp"

#include <algorithm>
#include <limits>

#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {

namespace {
constexpr std::size_t max_role = 64;
constexpr std::size_t max_node = 255;
}  // namespace

Bytes encode_hello(const Hello& hello) {
    Bytes fields;
    fields.insert(fields.end(), hello_magic.begin(), hello_magic.end());
    append_varint(fields, hello.version);
    append_string(fields, hello.role);
    append_string(fields, hello.node);
    fields.insert(fields.end(), hello.nonce.begin(), hello.nonce.end());
    fields.push_back(hello.has_secret ? hello_flag_secret : 0);
    append_varint(fields, hello.max_frame);
    Bytes out;
    append_frame(out, FrameType::hello, fields);
    return out;
}

Result<Hello> decode_hello(ByteView fields) {
    FieldReader reader(fields);
    const auto magic = reader.raw("hello magic", hello_magic.size());
    if (!magic) {
        return Error{reader.error()};
    }
    if (as_string_view(*magic) != hello_magic) {
        return Error{"not a Plexus peer: hello magic is not \"PLXS\""};
    }
    const auto version = reader.varint("hello version");
    if (!version) {
        return Error{reader.error()};
    }
    if (*version > std::numeric_limits<std::uint32_t>::max()) {
        return Error{"hello version " + std::to_string(*version) + " is out of range"};
    }
    Hello hello;
    hello.version = static_cast<std::uint32_t>(*version);
    const auto role = reader.string("hello role", max_role);
    const auto node = reader.string("hello node", max_node);
    if (reader.failed()) {
        // A peer of another version may lay out the rest differently. Its version is still
        // returned, so that the caller can answer "version mismatch" rather than "garbage".
        if (hello.version != protocol_version) {
            return hello;
        }
        return Error{reader.error()};
    }
    hello.role = std::string(*role);
    hello.node = std::string(*node);
    if (!reader.rest().empty()) {
        const auto nonce = reader.raw("hello nonce", hello.nonce.size());
        const auto flags = reader.byte("hello flags");
        if (!flags)
            return Error{reader.error()};
        std::copy(nonce->begin(), nonce->end(), hello.nonce.begin());
        hello.has_secret = (*flags & hello_flag_secret) != 0;
        if (!reader.rest().empty()) {
            const auto max_frame = reader.varint("hello max_frame");
            if (!max_frame)
                return Error{reader.error()};
            hello.max_frame = *max_frame;
        }
    }
    // Trailing bytes are ignored: a later version may append fields to its hello.
    return hello;
}

}  // namespace plexus::proto
