#include "request_parser.hpp"

#include <string>

#include "name_protocol.hpp"
#include "plexus/proto/name_operations.hpp"

namespace plexus::daemon::names {

proto::Result<proto::Request> parse_session_request(proto::FrameType type, proto::ByteView fields) {
    if (type != proto::FrameType::request) {
        return proto::Error{"the name server only takes requests, not " +
                            proto::frame_type_name(static_cast<std::uint8_t>(type)) + " frames"};
    }
    auto request = proto::decode_request(fields);
    if (!request)
        return proto::Error{"bad request: " + request.error().message};
    return request;
}

proto::Result<proto::Request> parse_datagram_request(proto::ByteView datagram, std::size_t max_datagram) {
    const proto::FrameDecoder decoder(max_datagram);
    const auto decoded = decoder.decode(datagram);
    // A datagram is read whole: a frame that needs more, or bytes after it, will never be completed.
    if (decoded.status != proto::DecodeStatus::frame || decoded.used != datagram.size() ||
        decoded.type != proto::FrameType::request) {
        return proto::Error{decoded.status == proto::DecodeStatus::bad
                                ? decoded.error
                                : "a datagram must hold exactly one request frame"};
    }
    auto request = proto::decode_request(decoded.fields);
    if (!request)
        return proto::Error{"bad request: " + request.error().message};
    return request;
}

std::optional<proto::Request> parse_discovery_query(proto::ByteView datagram, std::size_t max_frame) {
    const proto::FrameDecoder decoder(max_frame);
    const auto decoded = decoder.decode(datagram);
    if (decoded.status != proto::DecodeStatus::frame || decoded.type != proto::FrameType::request)
        return std::nullopt;
    auto request = proto::decode_request(decoded.fields);
    // decode_request made sure "op" is text.
    if (!request || proto::op_named(request->body["op"].get<std::string>()) != proto::DiscoverRequest::op ||
        !proto::DiscoverRequest::decode(request->body))
        return std::nullopt;
    return std::move(*request);
}

}  // namespace plexus::daemon::names
