#pragma once
// How `connect` (a warning) and `plexus events --check` put an overlap of two connections'
// constraints into words: the witness, an assignment of events under which both may deliver.

#include <map>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace plexus::daemon {

/// "e.g. with e_a present, e_b absent"; says so when the pair depends on no event, or when
/// there were too many events to try.
inline std::string describe_witness(const std::optional<std::map<std::string, bool>>& witness) {
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

/// {"e_a": true, "e_b": false}; null when there were too many events to try.
inline nlohmann::json witness_json(const std::optional<std::map<std::string, bool>>& witness) {
    if (!witness)
        return nullptr;
    nlohmann::json object = nlohmann::json::object();
    for (const auto& [event, present] : *witness)
        object[event] = present;
    return object;
}

}  // namespace plexus::daemon
