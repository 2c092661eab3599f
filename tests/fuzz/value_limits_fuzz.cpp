// Limits agree end to end. The input is a line as `plexus write` reads it (JSON when it parses,
// else a string), and also bytes as a reader receives them. Properties:
//   - a value the writer accepts (check_value_depth, what libplexus, the CLI and Python apply) is
//     encoded, and every reader decodes the encoding back to the same value;
//   - a value the writer refuses gets a reason that says why, and it is exactly a value nested
//     deeper than a reader decodes (no value is refused that a reader could have taken);
//   - whatever a reader decodes off the wire, a writer would have accepted: the two limits agree.
#include <cstddef>
#include <cstdint>
#include <string>

#include <nlohmann/json.hpp>

#include "fuzz_check.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/control.hpp"
#include "same_json.hpp"

namespace proto = plexus::proto;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const std::string line(reinterpret_cast<const char*>(data), size);
    nlohmann::json value = nlohmann::json::parse(line, nullptr, false);
    if (value.is_discarded())
        value = line;

    const bool shallow = proto::nesting_depth(value) <= proto::max_cbor_depth;
    const auto accepted = proto::check_value_depth(value, "the line");
    PLEXUS_FUZZ_CHECK(accepted.ok() == shallow);
    if (!accepted) {
        PLEXUS_FUZZ_CHECK(accepted.error().message.find("deeper than") != std::string::npos);
        // Had it been sent, no reader would have decoded it (encoded only when the encoder's
        // recursion is harmless: that recursion is why the writer checks first).
        if (proto::nesting_depth(value, 1000) <= 1000) {
            proto::Bytes encoded;
            proto::encode_cbor(value, encoded);
            PLEXUS_FUZZ_CHECK(!proto::decode_cbor(encoded).ok());
        }
    } else {
        proto::Bytes encoded;
        proto::encode_cbor(value, encoded);
        const auto decoded = proto::decode_cbor(encoded);
        PLEXUS_FUZZ_CHECK(decoded.ok());
        PLEXUS_FUZZ_CHECK(plexus::fuzz::same_json(*decoded, value));
    }

    const auto received = proto::decode_cbor(proto::ByteView(data, size));
    if (received)
        PLEXUS_FUZZ_CHECK(proto::check_value_depth(*received, "the payload").ok());
    return 0;
}
