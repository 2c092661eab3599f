#pragma once
// What arrives at the name server, turned into a request: pure functions, no sockets, so that unit
// tests and the fuzzers (tests/fuzz/) reach the parsing without starting a server.

#include <cstddef>
#include <optional>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/frame.hpp"

namespace plexus::daemon::names {

/// The request of a TCP session's frame; only request frames are taken. An Error is the reason the
/// session is cut off with.
proto::Result<proto::Request> parse_session_request(proto::FrameType type, proto::ByteView fields);

/// The request of a UDP datagram, which must hold exactly one request frame of at most
/// `max_datagram` bytes. An Error is the reason sent back in an error frame.
proto::Result<proto::Request> parse_datagram_request(proto::ByteView datagram, std::size_t max_datagram);

/// The request of a datagram sent to the discovery group when it is a discovery query (a request
/// frame {"op": "discover"} first in the datagram); nullopt for anything else, which gets no answer.
std::optional<proto::Request> parse_discovery_query(proto::ByteView datagram, std::size_t max_frame);

}  // namespace plexus::daemon::names
