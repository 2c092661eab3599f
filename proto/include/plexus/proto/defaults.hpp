#pragma once
// Where programs look for the name server and the local daemon when not told: shared by the
// daemon, the client library and the CLI so that they always agree.

#include <unistd.h>

#include <cstdlib>
#include <string>

namespace plexus::proto {

inline constexpr const char* default_names_address = "127.0.0.1:10100";

/// --names default: $PLEXUS_NAMES, else 127.0.0.1:10100.
inline std::string default_names() {
    const char* env = std::getenv("PLEXUS_NAMES");
    return env && *env ? env : default_names_address;
}

/// --socket default: $PLEXUS_SOCKET, else $XDG_RUNTIME_DIR/plexus/plexusd.sock,
/// else /tmp/plexus-UID/plexusd.sock.
inline std::string default_socket() {
    if (const char* env = std::getenv("PLEXUS_SOCKET"); env && *env)
        return env;
    if (const char* runtime = std::getenv("XDG_RUNTIME_DIR"); runtime && *runtime) {
        return std::string(runtime) + "/plexus/plexusd.sock";
    }
    return "/tmp/plexus-" + std::to_string(::getuid()) + "/plexusd.sock";
}

}  // namespace plexus::proto
