#pragma once
// Threading: the daemon's one thread.
//
// What the web endpoint did, and every request it refused by reason, for `plexus stats` and
// `/metrics`: a refusal nobody can count is a refusal nobody can see.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string_view>

#include <nlohmann/json.hpp>

namespace plexus::daemon::web {

enum class Refused {
    too_many_connections,  ///< over max_connections: 503
    header_too_large,      ///< request line and headers over header_limit: 431
    body,                  ///< a request with a body (every path is GET): 400
    bad_request,           ///< not HTTP/1.x: 400
    not_found,             ///< unknown path or port: 404
    method,                ///< not GET or HEAD: 405
    token,                 ///< beyond loopback without the web token: 401
    host,                  ///< no token and a Host header that names no address (DNS rebinding): 403
    read_timeout,  ///< a request that did not arrive whole in time (slow loris), or an idle connection
    slow_stream,   ///< a stream client that did not take its events in time
};
inline constexpr std::size_t refused_kinds = 10;

/// The label of a refusal in metrics and stats ("header_too_large").
std::string_view refused_name(Refused reason);

struct HttpCounters {
    std::uint64_t connections_accepted = 0;
    std::uint64_t connections_open = 0;  ///< now (a gauge)
    std::uint64_t requests = 0;          ///< requests answered, refusals included
    std::uint64_t stream_clients = 0;    ///< stream clients now (a gauge)
    std::uint64_t stream_events = 0;     ///< events written to stream clients
    std::array<std::uint64_t, refused_kinds> refused{};

    void count(Refused reason) { ++refused[static_cast<std::size_t>(reason)]; }
    /// `{"connections_accepted", ..., "refused": {"token": N, ...}}`.
    nlohmann::json to_json() const;
};

}  // namespace plexus::daemon::web
