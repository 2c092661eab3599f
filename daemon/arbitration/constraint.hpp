#pragma once
// A connection's constraint: a boolean expression over event names (DESIGN, "Arbitration by
// events and constraints"):
//     expr    = term { "or" term }
//     term    = factor { "and" factor }
//     factor  = "not" factor | "(" expr ")" | "true" | "false" | EVENT
//     EVENT   = a name of letters, digits and "_ . : / -" that is not a keyword
// Parsed into a tree once, evaluated for every message: an event name stands for "this event is
// in the container now". Nothing is done by text substitution, so `e_ball` and `e_ball_selected`
// are two unrelated names.

#include <functional>
#include <memory>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "plexus/proto/bytes.hpp"

namespace plexus::daemon::arbitration {

class Constraint {
public:
    /// Errors give the 0-based position in `text` and what was expected there, e.g.
    /// "constraint 'a and' at position 5: expected an event name, 'not', 'true', 'false' or '('".
    static proto::Result<Constraint> parse(std::string_view text);

    /// The value with `has_event(name)` answering for each event name.
    bool evaluate(const std::function<bool(const std::string&)>& has_event) const;
    /// The value under one assignment, given as the set of events that are present.
    bool evaluate(const std::set<std::string>& present) const;
    /// The event names the expression mentions, sorted, each once.
    const std::vector<std::string>& events() const { return events_; }
    /// The text it was parsed from.
    const std::string& text() const { return text_; }

    struct Node;

private:
    std::string text_;
    std::shared_ptr<const Node> root_;  ///< immutable, so copies can share it
    std::vector<std::string> events_;
};

}  // namespace plexus::daemon::arbitration
