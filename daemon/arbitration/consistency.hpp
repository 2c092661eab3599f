#pragma once
// The consistency check of DESIGN: over every assignment of the events the constraints mention,
// at most one non-auxiliary connection of a port may be allowed to deliver.

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "constraint.hpp"

namespace plexus::daemon::arbitration {

/// What the check needs to know of one connection.
struct Rule {
    std::string label;                       ///< the connection's source port
    const Constraint* constraint = nullptr;  ///< none: always true
    /// Connections under stimulation arbitration: the selection delivers one of them at a time,
    /// so two of them never overlap each other.
    bool stimulated = false;
};

struct Overlap {
    std::size_t first = 0;  ///< indexes into the rules
    std::size_t second = 0;
    /// Events present (true) or absent (false) under which both constraints are true; empty
    /// when neither constraint mentions an event. None when there were too many events to try.
    std::optional<std::map<std::string, bool>> witness;
};

/// Tries assignments of up to this many events per pair (2^16, a few ms on the daemon's thread);
/// past it, the pair is reported without a witness (as a possible overlap).
constexpr std::size_t max_checked_events = 16;

/// Every overlapping pair; with `only`, just the pairs that include rules[*only].
std::vector<Overlap> find_overlaps(const std::vector<Rule>& rules,
                                   std::optional<std::size_t> only = std::nullopt);

}  // namespace plexus::daemon::arbitration
