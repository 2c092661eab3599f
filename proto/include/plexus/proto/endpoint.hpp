#pragma once
// HOST:PORT strings as the command line and the name server use them.

#include <cstdint>
#include <string>
#include <string_view>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

struct Endpoint {
    std::string host;
    std::uint16_t port = 0;
    /// "HOST:PORT", with an IPv6 host in brackets ("[::1]:5000") so that it parses back.
    std::string text() const {
        const bool ipv6 = host.find(':') != std::string::npos;
        return (ipv6 ? "[" + host + "]" : host) + ":" + std::to_string(port);
    }
};

/// Parses "HOST:PORT" ("127.0.0.1:10100", "localhost:0", "[::1]:5000"). Port 0 is allowed (bind any).
/// An IPv6 host is returned without its brackets ("::1"), as a resolver wants it.
Result<Endpoint> parse_endpoint(std::string_view text);

}  // namespace plexus::proto
