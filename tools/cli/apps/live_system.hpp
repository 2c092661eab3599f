#pragma once
// What `up`, `up --diff` and `down` ask of the running system, through the local daemon: its node,
// which ports are registered, which connections exist with which carrier; and the changes they make.

#include <optional>
#include <string>
#include <vector>

#include "plexus/client.hpp"

namespace plexus::cli {

struct LiveConnection {
    std::string source;
    std::string destination;
    std::string carrier;
    bool persistent = false;
    bool live = false;  ///< both ports registered now
};

/// Whether a connection made with `wanted` (as the file writes it; "" lets the daemon choose)
/// is what a connection with the daemon's canonical `live` carrier text is.
bool same_carrier(const std::string& wanted, const std::string& live);

class LiveSystem {
public:
    /// Connects to the daemon at `socket`; throws Error (refused) when none answers there.
    explicit LiveSystem(const std::string& socket);

    /// The local daemon's node name.
    std::string node();
    bool port_exists(const std::string& port);
    std::vector<LiveConnection> connections();
    /// The connection SRC -> DST among `all`, if there is one.
    static std::optional<LiveConnection> find(const std::vector<LiveConnection>& all,
                                              const std::string& source, const std::string& destination);
    /// Makes a connection; returns the daemon's warnings. Throws Error when refused.
    std::vector<std::string> connect(const std::string& source, const std::string& destination,
                                     const std::string& carrier, bool persist);
    void disconnect(const std::string& source, const std::string& destination);

private:
    Client client_;
};

}  // namespace plexus::cli
