#pragma once
// The directory of plexusd's Unix socket. Whoever may write in it may replace the socket with
// one of their own, and every local client would then talk to them: so it must be the daemon's
// user's alone (docs/SECURITY.md, "Local clients").

#include <filesystem>

#include "plexus/proto/bytes.hpp"

namespace plexus::daemon {

/// Makes `directory` (mode 0700, with any missing parents) when it does not exist. Refuses it,
/// with an error naming what is wrong and what to do, when it is not a directory, belongs to
/// another user than the daemon's, or may be written by its group or by others.
proto::Status prepare_socket_directory(const std::filesystem::path& directory);

}  // namespace plexus::daemon
