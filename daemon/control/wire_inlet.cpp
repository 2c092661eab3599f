// Wiring a connection into a port of this daemon: the steps `connect` (local) and `attach` share.
#include "wire_inlet.hpp"

#include <mutex>

#include <spdlog/spdlog.h>

#include "arbitration/carrier_rules.hpp"
#include "inspect/overlap_text.hpp"
#include "monitor_wiring.hpp"

namespace plexus::daemon {

namespace {

/// A new connection's place in the arbitration of `port`, configured from the carrier.
proto::Result<std::shared_ptr<arbitration::Member>> new_member(const arbitration::Clock& clock,
                                                               const std::shared_ptr<Port>& port,
                                                               const std::string& source,
                                                               const proto::Carrier& carrier) {
    if (!port->arbiter)
        port->arbiter = std::make_shared<arbitration::Arbiter>(clock);
    auto member = std::make_shared<arbitration::Member>(port->arbiter, source);
    if (auto configured = arbitration::configure_member(*member, carrier); !configured)
        return configured.error();
    return member;
}

/// Checks a member before it joins: weights that make the system singular are an error;
/// constraints that overlap another connection's are warnings (errors with `strict`).
proto::Result<nlohmann::json> check_member(const Port& port, const arbitration::Member& member, bool strict) {
    auto& arbiter = *port.arbiter;
    if (auto weights = arbiter.check_weights(member); !weights)
        return proto::Error{"connection from " + member.source() + " into " + port.name() +
                            " refused: " + weights.error().message};
    nlohmann::json warnings = nlohmann::json::array();
    // Plain fan-in (no constraints anywhere) is not arbitration: nothing to warn about.
    if (!arbiter.uses_constraints(&member))
        return warnings;
    for (const auto& pair : arbiter.overlaps(&member)) {
        warnings.push_back("connections from " + pair.first + " and " + pair.second + " into " + port.name() +
                           " can both deliver at once, " + describe_witness(pair.witness));
    }
    if (strict && !warnings.empty())
        return proto::Error{"--strict: " + warnings[0].get<std::string>()};
    for (const auto& warning : warnings)
        spdlog::warn("arbitration: {}", warning.get<std::string>());
    return warnings;
}

}  // namespace

proto::Result<WiredInlet> wire_inlet(MonitorWiring& scripts, const arbitration::Clock& clock,
                                     const InletSpec& spec, const InletHandOver& hand_over) {
    const auto& port = spec.port;
    auto member = new_member(clock, port, spec.source, spec.carrier);
    if (!member)
        return member.error();
    auto recv_chain =
        scripts.build_chain(spec.carrier, proto::Side::recv, spec.source, port->name(), *member);
    if (!recv_chain)
        return recv_chain.error();
    proto::Result<nlohmann::json> warnings = nlohmann::json::array();
    {
        std::lock_guard lock(port->arbiter->mutex());
        warnings = check_member(*port, **member, spec.strict);
    }
    if (!warnings)
        return warnings.error();
    auto inlet = std::make_shared<Inlet>(port, spec.source, spec.carrier_name, *member);
    if (*recv_chain) {
        monitor::MonitorStage::Options options;
        options.drop_oldest = port->queue().policy() == QueuePolicy::latest;
        inlet->monitors = scripts.make_stage(std::move(*recv_chain), *member, options, inlet);
    }
    if (hand_over) {
        if (auto handed = hand_over(inlet); !handed)
            return handed.error();
    }
    // Connections that were removed leave expired entries: drop them as new ones come.
    std::erase_if(port->inbound, [](const std::weak_ptr<Inlet>& entry) { return entry.expired(); });
    port->inbound.push_back(inlet);
    if (spec.carrier.qos.prio)
        port->ask_priority(inlet, *spec.carrier.qos.prio);
    std::lock_guard lock(port->arbiter->mutex());
    port->arbiter->join(**member);
    return WiredInlet{std::move(inlet), std::move(*warnings)};
}

}  // namespace plexus::daemon
