#include "node_view.hpp"

#include "core/router.hpp"
#include "events_view.hpp"
#include "stats_view.hpp"

namespace plexus::daemon::inspect {

nlohmann::json node_view(ControlHost& host, const ShmUsage& shm) {
    nlohmann::json view = arbitration_view(host);
    view["address"] = host.address();
    view["stats"] = stats_view(host, shm, "");
    return view;
}

nlohmann::json arbitration_view(ControlHost& host) {
    nlohmann::json ports = nlohmann::json::array();
    const double now = host.clock().now();
    for (const auto& [name, port] : host.router().ports()) {
        // A port is arbitrated once something connects into it (the arbiter is made then); one
        // whose connections all went keeps its arbiter, and is left out until one comes again.
        const bool connected = std::any_of(port->inbound.begin(), port->inbound.end(),
                                           [](const auto& in) { return !in.expired(); });
        if (port->arbiter && connected)
            ports.push_back(events_view(*port, false, host.config().node, now));
    }
    return {{"node", host.config().node}, {"arbitration", std::move(ports)}};
}

}  // namespace plexus::daemon::inspect
