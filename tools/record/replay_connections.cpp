#include "replay_connections.hpp"

#include "arbitration/carrier_rules.hpp"
#include "monitor/carrier_monitors.hpp"

namespace plexus::record {

namespace arbitration = daemon::arbitration;
namespace monitor = daemon::monitor;

ReplayConnections::ReplayConnections(const RecordedPort& port)
    : host_(clock_, port.clock), arbiter_(std::make_shared<arbitration::Arbiter>(clock_)) {
    clock_.set(port.clock.started_clock);
}

ReplayConnections::~ReplayConnections() {
    // The monitors first (their destroy() may still use events), then the members leave.
    for (auto& connection : connections_)
        connection.monitors.reset();
    connections_.clear();
}

proto::Result<std::unique_ptr<ReplayConnections>> ReplayConnections::build(
    const RecordedPort& port, const std::vector<std::string>& carriers, const Places& places) {
    std::unique_ptr<ReplayConnections> replay(new ReplayConnections(port));
    const monitor::ChainPlaces chain_places{places.script_dirs, places.monitor_lib_dirs, places.policy};
    for (std::size_t i = 0; i < port.connections.size(); ++i) {
        const std::string& source = port.connections[i].source;
        const auto refuse = [&](const std::string& why) {
            return proto::Error{"connection from " + source + " (" + carriers[i] + "): " + why};
        };
        auto carrier = proto::parse_carrier(carriers[i]);
        if (!carrier)
            return refuse(carrier.error().message);
        if (auto valid = proto::validate_carrier(*carrier); !valid)
            return refuse(valid.error().message);
        auto member = std::make_shared<arbitration::Member>(replay->arbiter_, source);
        if (auto configured = arbitration::configure_member(*member, *carrier); !configured)
            return refuse(configured.error().message);
        auto chain = monitor::build_carrier_chain(*carrier, proto::Side::recv, source, port.port, member,
                                                  chain_places, replay->host_);
        if (!chain)
            return refuse(chain.error().message);
        if (auto weights = replay->arbiter_->check_weights(*member); !weights)
            return refuse(weights.error().message);
        replay->arbiter_->join(*member);
        replay->connections_.push_back({source, carriers[i], std::move(member), std::move(*chain)});
    }
    return replay;
}

std::uint64_t ReplayConnections::script_errors() const {
    std::uint64_t errors = 0;
    for (const auto& connection : connections_) {
        if (!connection.monitors)
            continue;
        for (const auto& monitor : connection.monitors->monitors)
            errors += monitor->counters().errors;
    }
    return errors;
}

}  // namespace plexus::record
