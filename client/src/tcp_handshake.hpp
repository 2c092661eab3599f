#pragma once
// The hello exchange on a TCP connection from a client (the CLI asking a name server or a remote
// daemon), done before the connection is handed to Connection: with the deployment secret, both
// sides prove they hold it (PROTOCOL.md, "Authentication").

#include <chrono>
#include <cstdint>
#include <string>

namespace plexus::detail {

/// Exchanges hellos on the connected socket `fd` (and proofs when either side has a secret:
/// $PLEXUS_SECRET_FILE). Throws Error (refused) with the peer's reason when it refuses us, or when
/// it does not prove it holds our secret. Blocking, within `timeout`. Answers the largest frame
/// body the peer takes (0: it did not say).
std::uint64_t tcp_handshake(int fd, const std::string& address, std::chrono::milliseconds timeout);

}  // namespace plexus::detail
