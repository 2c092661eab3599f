#pragma once
// Who plexusd and plexus-names trust (docs/SECURITY.md): the deployment secret they load, and the
// rule that without one they listen on loopback only, unless told --insecure.

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/permissions.hpp"
#include "net/permission_gate.hpp"
#include "plexus/proto/auth.hpp"
#include "plexus/proto/identity.hpp"

namespace plexus::daemon {

/// The secret named by `flag_path` (--secret-file), else by $PLEXUS_SECRET_FILE; none when neither
/// is set. An Error when a named file cannot be used (missing, readable by others, too short).
/// With the identity named by `identity_flag` (--identity), else by $PLEXUS_IDENTITY, the secret
/// carries it (proto::Secret::set_identity): it must be a certificate of `kind` (a daemon's is a
/// node's, a name server's a name server's), and there must be a secret.
proto::Result<std::optional<proto::Secret>> load_deployment_secret(
    const std::string& flag_path, const std::string& identity_flag = {},
    proto::Subject::Kind kind = proto::Subject::Kind::node);

/// The permissions file at `path` (--permissions), read and checked; null when `path` is empty
/// (everyone may do everything).
proto::Result<std::shared_ptr<const Permissions>> load_permissions(const std::string& path);

/// On SIGHUP: reads `gate`'s permissions file again and logs what came of it (`log_prefix` starts
/// the line: "names: " for a name server). A file that cannot be used leaves the old rules.
void reload_permissions(PermissionGate& gate, std::string_view log_prefix);

/// Refuses to listen on any of `hosts` beyond loopback without a secret, unless `insecure`; with
/// `insecure` and no secret, logs a loud warning (at every start, on purpose).
proto::Status check_listening(const std::vector<std::string>& hosts, bool has_secret, bool insecure,
                              const std::string& program);

}  // namespace plexus::daemon
