#include "plan.hpp"

#include <set>

#include "component_process.hpp"

namespace plexus::cli {

std::vector<ComponentStep> plan_components(const app::App& app, const Where& where, const AppState& state,
                                           LiveSystem& live, std::vector<std::string>& problems) {
    std::vector<ComponentStep> steps;
    for (const auto& component : app.components) {
        ComponentStep step;
        step.component = &component;
        // A component without a node, or on the local daemon's node, runs under the local daemon.
        step.node = component.node.empty() ? where.local_node : component.node;
        if (where.only_node && *where.only_node != step.node) {
            step.action = ComponentStep::Action::other_node;
            steps.push_back(step);
            continue;
        }
        if (step.node == where.local_node) {
            step.socket = where.local_socket;
        } else if (auto it = where.node_sockets.find(step.node); it != where.node_sockets.end()) {
            step.socket = it->second;
        } else {
            problems.push_back(app.file + ": " + component.label() +
                               ": \"node\": no daemon socket known for node '" + step.node +
                               "' (the local daemon is node '" + where.local_node +
                               "'): pass --node-socket " + step.node +
                               "=PATH if its daemon runs on this "
                               "machine, or run `plexus up " +
                               app.file + " --only-node " + step.node + "` on the machine where it runs");
        }
        if (auto it = state.components.find(component.name);
            it != state.components.end() && still_running(it->second)) {
            step.action = ComponentStep::Action::running;
        } else if (!component.ports.empty()) {
            bool all = true;
            for (const auto& port : component.ports)
                all = all && live.port_exists(port);
            if (all)
                step.action = ComponentStep::Action::running_outside;
        }
        steps.push_back(step);
    }
    return steps;
}

std::vector<ConnectionStep> plan_connections(const app::App& app, const std::vector<LiveConnection>& live) {
    std::vector<ConnectionStep> steps;
    for (const auto& connection : app.connections) {
        ConnectionStep step;
        step.connection = &connection;
        step.live = LiveSystem::find(live, connection.source, connection.destination);
        if (!step.live)
            step.action = ConnectionStep::Action::make;
        else if (same_carrier(connection.carrier, step.live->carrier))
            step.action = ConnectionStep::Action::present;
        else
            step.action = ConnectionStep::Action::replace;
        steps.push_back(step);
    }
    return steps;
}

std::vector<LiveConnection> foreign_connections(const app::App& app,
                                                const std::vector<LiveConnection>& live) {
    std::set<std::string> destinations;
    std::set<std::pair<std::string, std::string>> ours;
    for (const auto& connection : app.connections) {
        destinations.insert(connection.destination);
        ours.emplace(connection.source, connection.destination);
    }
    std::vector<LiveConnection> foreign;
    for (const auto& c : live) {
        if (destinations.count(c.destination) && !ours.count({c.source, c.destination}))
            foreign.push_back(c);
    }
    return foreign;
}

}  // namespace plexus::cli
