#pragma once
// Who plexusd and plexus-names trust (docs/SECURITY.md): the deployment secret they load, and the
// rule that without one they listen on loopback only, unless told --insecure.

#include <optional>
#include <string>
#include <vector>

#include "plexus/proto/auth.hpp"

namespace plexus::daemon {

/// The secret named by `flag_path` (--secret-file), else by $PLEXUS_SECRET_FILE; none when neither
/// is set. An Error when a named file cannot be used (missing, readable by others, too short).
proto::Result<std::optional<proto::Secret>> load_deployment_secret(const std::string& flag_path);

/// Refuses to listen on any of `hosts` beyond loopback without a secret, unless `insecure`; with
/// `insecure` and no secret, logs a loud warning (at every start, on purpose).
proto::Status check_listening(const std::vector<std::string>& hosts, bool has_secret, bool insecure,
                              const std::string& program);

}  // namespace plexus::daemon
