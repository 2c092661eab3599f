#pragma once
// Threading: read-only once loaded; shared by threads.
//
// Permissions (docs/SECURITY.md, "Permissions"): which node, and which local user, may open,
// write, read, connect or attach monitors to which ports. In the spirit of SROS2's permissions
// and NATS's per-subject rules: a file of rules, each naming who, which actions and which ports
// by patterns; with a file, what no rule allows is refused. Without one, everything is allowed as
// before. Checked when a port is opened, a connection made or a link attached, never per message.
//
//   {"rules": [
//     {"nodes": ["arm"],           "allow": ["open", "read", "write", "connect", "monitor"], "ports":
//     ["/arm/**"]},
//     {"nodes": ["planner"],       "allow": ["write"],  "ports": ["/arm/cmd"]},
//     {"nodes": ["*"],             "allow": ["read"],   "ports": ["/arm/state"]},
//     {"users": [1000, "robot"],   "allow": ["open", "connect", "read", "write"], "ports": ["/ui/*"]}]}
//
// Port patterns: `*` is any text within one segment (no '/'), `**` any text at all. Node
// patterns: `*` is any text. A node is a remote daemon or TCP client, known by its certificate
// with identities (else by its hello, which the secret vouches for); a user is a local component,
// known by the uid the kernel gives for its Unix socket (a name is looked up when the file is read).

#include <sys/types.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "plexus/proto/bytes.hpp"

namespace plexus::daemon {

enum class Action : unsigned { open = 1, write = 2, read = 4, connect = 8, monitor = 16 };
std::string_view action_name(Action action);

/// Who asks: a node, or a local user.
struct Principal {
    std::optional<std::string> node;
    std::optional<uid_t> user;
    /// "node 'arm'", "user 1000", "an unnamed peer".
    std::string text() const;
};

/// True when `port` matches `pattern` (`*` within a segment, `**` across them).
bool port_matches(std::string_view pattern, std::string_view port);
/// True when `node` matches `pattern` (`*` any text).
bool node_matches(std::string_view pattern, std::string_view node);

class Permissions {
public:
    /// Reads a permissions file; an Error names the file and what is wrong in it.
    static proto::Result<Permissions> load(const std::string& path);
    /// From the file's JSON; `source` names it in messages.
    static proto::Result<Permissions> parse(const nlohmann::json& file, const std::string& source);

    bool allows(const Principal& who, Action action, std::string_view port) const;
    const std::string& source() const { return source_; }
    std::size_t rule_count() const { return rules_.size(); }

private:
    struct Rule {
        std::vector<std::string> nodes;
        std::vector<uid_t> users;
        std::vector<std::string> ports;
        unsigned actions = 0;
    };
    std::vector<Rule> rules_;
    std::string source_;
};

}  // namespace plexus::daemon
