// The name server's request parsing (daemon/names/request_parser.hpp): a TCP session's frame, a
// UDP datagram, a datagram sent to the discovery group. The input is what arrives: a datagram, or
// the bytes of a stream (frames decoded one after the other, as a session reads them).
// Properties: a request taken has a map body with a string "op" (what the server's handler
// relies on) and encodes to a datagram that is taken back as the same request; a discovery query
// is a "discover"; a refusal always has a reason.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_check.hpp"
#include "names/request_parser.hpp"
#include "plexus/proto/frame.hpp"
#include "same_json.hpp"

namespace names = plexus::daemon::names;
namespace proto = plexus::proto;

namespace {

constexpr std::size_t max_datagram = 65507;     // as NameServer::udp_loop reads them
constexpr std::size_t max_frame = 1024 * 1024;  // NameServerConfig::max_frame

void check_request(const proto::Request& request) {
    PLEXUS_FUZZ_CHECK(request.body.is_object());
    const auto op = request.body.find("op");
    PLEXUS_FUZZ_CHECK(op != request.body.end() && op->is_string());
    const auto datagram = proto::encode_request(request);
    if (datagram.size() > max_datagram)
        return;
    const auto again = names::parse_datagram_request(datagram, max_datagram);
    PLEXUS_FUZZ_CHECK(again.ok() && again->id == request.id &&
                      plexus::fuzz::same_json(again->body, request.body));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    const proto::ByteView input(data, size);
    const auto datagram = names::parse_datagram_request(input, max_datagram);
    if (datagram)
        check_request(*datagram);
    else
        PLEXUS_FUZZ_CHECK(!datagram.error().message.empty());

    if (const auto query = names::parse_discovery_query(input, 2048)) {
        PLEXUS_FUZZ_CHECK(query->body.value("op", std::string{}) == "discover");
        check_request(*query);
    }

    // The stream of a TCP session: every frame goes to the parser until one is refused.
    const proto::FrameDecoder decoder(max_frame);
    for (std::size_t at = 0; at < size;) {
        const auto frame = decoder.decode(input.subspan(at));
        if (frame.status != proto::DecodeStatus::frame)
            break;
        at += frame.used;
        const auto request = names::parse_session_request(frame.type, frame.fields);
        if (!request) {
            PLEXUS_FUZZ_CHECK(!request.error().message.empty());
            break;
        }
        check_request(*request);
    }
    return 0;
}
