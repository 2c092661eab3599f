// `plexus events PORT`: the port's event container, the constraints and stimulation of the
// connections into it, and their counters. (A connection's place in the arbitration is made in
// wire_inlet.cpp.)
#include "events_view.hpp"

#include <mutex>

#include "inlet_counters.hpp"
#include "overlap_text.hpp"

namespace plexus::daemon::inspect {

nlohmann::json events_view(const Port& port, bool check, const std::string& node, double now) {
    nlohmann::json body{{"port", port.name()}, {"node", node}};
    nlohmann::json events = nlohmann::json::array();
    nlohmann::json connections = nlohmann::json::array();
    nlohmann::json overlaps = nlohmann::json::array();
    nlohmann::json winner = nullptr;
    if (port.arbiter) {
        // The counters first: they take the arbiter's lock themselves.
        std::vector<std::pair<std::shared_ptr<Inlet>, nlohmann::json>> inlets;
        for (const auto& weak : port.inbound) {
            if (auto inlet = weak.lock())
                inlets.emplace_back(inlet, inlet_counters(*inlet));
        }
        auto& arbiter = *port.arbiter;
        std::lock_guard lock(arbiter.mutex());  // the port's monitors may be changing it meanwhile
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
        for (const auto& [inlet, counters] : inlets) {
            const auto& member = inlet->member();
            nlohmann::json entry{{"source", inlet->source()},
                                 {"carrier", inlet->carrier()},
                                 {"aux", member.aux},
                                 {"constraint", nullptr},
                                 {"constraint_value", arbiter.constraint_value(member)},
                                 {"priority", nullptr},
                                 {"counters", counters}};
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

}  // namespace plexus::daemon::inspect
