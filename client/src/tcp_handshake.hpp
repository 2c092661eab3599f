#pragma once
// The start of a TCP connection from a client (the CLI asking a name server or a remote daemon),
// done before the connection is handed to Connection: with the deployment secret
// ($PLEXUS_SECRET_FILE), the TLS handshake that proves both ends hold it (proto/tls_psk.hpp), then
// the hello exchange inside it.

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "plexus/proto/auth.hpp"
#include "tls_channel.hpp"

namespace plexus::detail {

struct TcpGreeting {
    std::uint64_t peer_max_frame = 0;  ///< the largest frame body the peer takes (0: it did not say)
    std::unique_ptr<TlsChannel> tls;   ///< the link's TLS, when there is a secret
};

/// Starts TLS on the connected socket `fd` when there is a secret, and exchanges hellos. Throws
/// Error (refused) with the peer's reason when it refuses us, when the TLS handshake fails, or when
/// the peer's hello gives another role than `expected_role` ("names").
/// Blocking, within `timeout`.
TcpGreeting tcp_handshake(int fd, const std::string& address, const std::string& expected_role,
                          std::chrono::milliseconds timeout);

/// The deployment secret named by $PLEXUS_SECRET_FILE; nullopt when unset. Throws Error (usage)
/// when the file cannot be read or is open to others.
std::optional<proto::Secret> secret_from_environment();

}  // namespace plexus::detail
