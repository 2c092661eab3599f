// decode_cbor_fast on arbitrary bytes. Properties, when it decodes:
//   - encode_cbor writes exactly what nlohmann::json::to_cbor writes (its promise in cbor.hpp);
//   - decoding that encoding gives the same value (decode after encode is the identity);
//   - nlohmann's own from_cbor reads the encoding to the same value (cbor.hpp: "it builds the same
//     json as from_cbor for everything to_cbor writes").
#include <cstddef>
#include <cstdint>

#include <nlohmann/json.hpp>

#include "fuzz_check.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/control.hpp"
#include "same_json.hpp"

namespace proto = plexus::proto;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const proto::ByteView input(data, size);
    const auto decoded = proto::decode_cbor_fast(input);
    // decode_cbor is the same decoder with a prefix on its reasons.
    PLEXUS_FUZZ_CHECK(proto::decode_cbor(input).ok() == decoded.ok());
    if (!decoded) {
        PLEXUS_FUZZ_CHECK(!decoded.error().message.empty());
        return 0;
    }
    proto::Bytes encoded;
    proto::encode_cbor(*decoded, encoded);
    PLEXUS_FUZZ_CHECK(encoded == nlohmann::json::to_cbor(*decoded));

    const auto again = proto::decode_cbor_fast(encoded);
    PLEXUS_FUZZ_CHECK(again.ok());
    PLEXUS_FUZZ_CHECK(plexus::fuzz::same_json(*again, *decoded));

    const auto reference =
        nlohmann::json::from_cbor(encoded, true, false, nlohmann::json::cbor_tag_handler_t::store);
    PLEXUS_FUZZ_CHECK(!reference.is_discarded());
    PLEXUS_FUZZ_CHECK(plexus::fuzz::same_json(reference, *decoded));
    return 0;
}
