// Arbitration in the daemon: a connection's place in its input port's arbitration when it is
// made, and `plexus events PORT` (the event container, constraints, stimulation, counters).
#include <spdlog/spdlog.h>

#include "arbitration/carrier_rules.hpp"
#include "daemon.hpp"
#include "inlet_counters.hpp"
#include "request_fields.hpp"

namespace plexus::daemon {

namespace {

/// "e_a present, e_b absent"; "any events" when the pair does not depend on events.
std::string describe_witness(const std::optional<std::map<std::string, bool>>& witness) {
    if (!witness)
        return "possibly (too many events to try every assignment)";
    if (witness->empty())
        return "always (neither depends on an event)";
    std::string text = "e.g. with ";
    bool first = true;
    for (const auto& [event, present] : *witness) {
        text += (first ? "" : ", ") + event + (present ? " present" : " absent");
        first = false;
    }
    return text;
}

nlohmann::json witness_json(const std::optional<std::map<std::string, bool>>& witness) {
    if (!witness)
        return nullptr;
    nlohmann::json object = nlohmann::json::object();
    for (const auto& [event, present] : *witness)
        object[event] = present;
    return object;
}

}  // namespace

proto::Result<std::shared_ptr<arbitration::Member>> Daemon::new_member(const std::shared_ptr<Port>& port,
                                                                       const std::string& source,
                                                                       const proto::Carrier& carrier) {
    if (!port->arbiter)
        port->arbiter = std::make_shared<arbitration::Arbiter>(clock_);
    auto member = std::make_shared<arbitration::Member>(port->arbiter, source);
    if (auto configured = arbitration::configure_member(*member, carrier); !configured)
        return configured.error();
    return member;
}

proto::Result<nlohmann::json> Daemon::check_member(const Port& port, const arbitration::Member& member,
                                                   bool strict) {
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

Task<proto::Reply> Daemon::events(const proto::Request& request) {
    const std::string name = text(request.body, "port");
    auto port = router_.find(name);
    if (!port)
        co_return co_await forward(request, name);
    co_return ok(events_json(*port, request.body.value("check", false)));
}

nlohmann::json Daemon::events_json(const Port& port, bool check) const {
    const double now = clock_.now();
    nlohmann::json body{{"port", port.name()}, {"node", config_.node}};
    nlohmann::json events = nlohmann::json::array();
    nlohmann::json connections = nlohmann::json::array();
    nlohmann::json overlaps = nlohmann::json::array();
    nlohmann::json winner = nullptr;
    if (port.arbiter) {
        auto& arbiter = *port.arbiter;
        for (const auto& entry : arbiter.events().entries(now)) {
            nlohmann::json left = nullptr;
            if (entry.expires)
                left = *entry.expires - now;
            events.push_back({{"name", entry.name}, {"owner", entry.owner_label}, {"time_left", left}});
        }
        const auto state = arbiter.priority_state();
        if (state.error)
            body["inconsistent"] = *state.error;
        if (state.winner)
            winner = state.members[*state.winner]->source();
        for (const auto& weak : port.inbound) {
            auto inlet = weak.lock();
            if (!inlet)
                continue;
            const auto& member = inlet->member();
            nlohmann::json entry{{"source", inlet->source()},
                                 {"carrier", inlet->carrier()},
                                 {"aux", member.aux},
                                 {"constraint", nullptr},
                                 {"constraint_value", arbiter.constraint_value(member)},
                                 {"priority", nullptr},
                                 {"counters", inlet_counters(*inlet)}};
            if (member.constraint)
                entry["constraint"] = member.constraint->text();
            for (std::size_t i = 0; i < state.members.size(); ++i) {
                if (state.members[i] != &member)
                    continue;
                entry["priority"] = {{"S", state.level[i]},
                                     {"x", state.active[i] ? 1 : 0},
                                     {"y", state.output[i]},
                                     {"winner", state.winner == i}};
            }
            connections.push_back(entry);
        }
        if (check) {
            for (const auto& pair : arbiter.overlaps())
                overlaps.push_back({{"first", pair.first},
                                    {"second", pair.second},
                                    {"witness", witness_json(pair.witness)},
                                    {"explanation", describe_witness(pair.witness)}});
        }
    }
    body["events"] = events;
    body["connections"] = connections;
    body["winner"] = winner;
    if (check)
        body["overlaps"] = overlaps;
    return body;
}

}  // namespace plexus::daemon
