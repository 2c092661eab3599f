#pragma once
// The difference between an application file and the live system: which components to start,
// which connections to make or replace. `up` carries it out; `up --diff` prints it.

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "app_file.hpp"
#include "app_state.hpp"
#include "live_system.hpp"

namespace plexus::cli {

struct ComponentStep {
    enum class Action {
        start,            ///< not running: start it
        running,          ///< started by an earlier `up` and still the same process
        running_outside,  ///< not ours, but every port it declares is registered: someone runs it
        other_node,       ///< --only-node names another node: left to the `up` on that machine
    };
    const app::Component* component = nullptr;
    Action action = Action::start;
    std::string socket;  ///< the PLEXUS_SOCKET of its node's daemon
    std::string node;    ///< its node ("" in the file = the local daemon's)
};

struct ConnectionStep {
    enum class Action {
        make,     ///< missing
        present,  ///< there with the file's carrier
        replace,  ///< there with another carrier (drift)
    };
    const app::AppConnection* connection = nullptr;
    Action action = Action::make;
    std::optional<LiveConnection> live;  ///< what is there now
};

struct Where {
    std::string local_socket;
    std::string local_node;
    std::map<std::string, std::string> node_sockets;  ///< --node-socket
    std::optional<std::string> only_node;
};

/// What to do with each component, given the state file and the registered ports.
std::vector<ComponentStep> plan_components(const app::App& app, const Where& where, const AppState& state,
                                           LiveSystem& live, std::vector<std::string>& problems);

/// What to do with each connection, given the live connections.
std::vector<ConnectionStep> plan_connections(const app::App& app, const std::vector<LiveConnection>& live);

/// Live connections into the file's destination ports that the file does not have.
std::vector<LiveConnection> foreign_connections(const app::App& app, const std::vector<LiveConnection>& live);

}  // namespace plexus::cli
