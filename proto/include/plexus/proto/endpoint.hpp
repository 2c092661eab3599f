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
    std::string text() const { return host + ":" + std::to_string(port); }
};

/// Parses "HOST:PORT" ("127.0.0.1:10100", "localhost:0", "[::1]:5000"). Port 0 is allowed (bind any).
Result<Endpoint> parse_endpoint(std::string_view text);

}  // namespace plexus::proto
