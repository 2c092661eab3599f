#include "consistency.hpp"

#include <algorithm>
#include <set>

namespace plexus::daemon::arbitration {

namespace {

bool holds(const Rule& rule, const std::set<std::string>& present) {
    return !rule.constraint || rule.constraint->evaluate(present);
}

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
    const std::uint64_t assignments = std::uint64_t{1} << events.size();
    for (std::uint64_t bits = 0; bits < assignments; ++bits) {
        std::set<std::string> present;
        for (std::size_t k = 0; k < events.size(); ++k) {
            if (bits & (std::uint64_t{1} << k))
                present.insert(events[k]);
        }
        if (holds(rules[a], present) && holds(rules[b], present)) {
            std::map<std::string, bool> witness;
            for (const auto& event : events)
                witness[event] = present.count(event) > 0;
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
