#include "consistency.hpp"

#include <algorithm>
#include <functional>
#include <unordered_map>

namespace plexus::daemon::arbitration {

namespace {

std::optional<Overlap> overlap_of(const std::vector<Rule>& rules, std::size_t a, std::size_t b) {
    std::vector<std::string> events;
    for (const auto* rule : {&rules[a], &rules[b]}) {
        if (rule->constraint)
            events.insert(events.end(), rule->constraint->events().begin(), rule->constraint->events().end());
    }
    std::sort(events.begin(), events.end());
    events.erase(std::unique(events.begin(), events.end()), events.end());
    if (events.size() > max_checked_events)
        return Overlap{a, b, std::nullopt};
    // Assignment `bits`: event k is present when bit k is set. Evaluated straight from the bits,
    // since this runs on the daemon's one thread up to 2 x 2^16 times.
    std::unordered_map<std::string, std::size_t> index;
    for (std::size_t k = 0; k < events.size(); ++k)
        index.emplace(events[k], k);
    std::uint64_t bits = 0;
    const std::function<bool(const std::string&)> present = [&](const std::string& name) {
        return (bits >> index.at(name)) & 1u;
    };
    auto holds = [&](const Rule& rule) { return !rule.constraint || rule.constraint->evaluate(present); };
    const std::uint64_t assignments = std::uint64_t{1} << events.size();
    for (bits = 0; bits < assignments; ++bits) {
        if (holds(rules[a]) && holds(rules[b])) {
            std::map<std::string, bool> witness;
            for (std::size_t k = 0; k < events.size(); ++k)
                witness[events[k]] = ((bits >> k) & 1u) != 0;
            return Overlap{a, b, witness};
        }
    }
    return std::nullopt;
}

}  // namespace

std::vector<Overlap> find_overlaps(const std::vector<Rule>& rules, std::optional<std::size_t> only) {
    std::vector<Overlap> found;
    for (std::size_t a = 0; a < rules.size(); ++a) {
        for (std::size_t b = a + 1; b < rules.size(); ++b) {
            if (only && a != *only && b != *only)
                continue;
            if (rules[a].stimulated && rules[b].stimulated)
                continue;
            if (auto overlap = overlap_of(rules, a, b))
                found.push_back(std::move(*overlap));
        }
    }
    return found;
}

}  // namespace plexus::daemon::arbitration
