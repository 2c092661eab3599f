#include "warm_up.hpp"

#include <algorithm>
#include <limits>
#include <optional>

#include "arbitration/stimulation.hpp"
#include "plexus/proto/carrier.hpp"

namespace plexus::record {

namespace {

/// The recv.priority parameters of a carrier; none without that clause (or when it does not parse:
/// the re-run has refused it by then).
std::optional<daemon::arbitration::PriorityParams> priority_of(const std::string& text) {
    auto carrier = proto::parse_carrier(text);
    if (!carrier)
        return std::nullopt;
    for (const auto& clause : carrier->clauses) {
        if (clause.side == proto::Side::recv && clause.modifier == "priority") {
            auto params = daemon::arbitration::PriorityParams::from_clause(clause);
            if (params)
                return *params;
        }
    }
    return std::nullopt;
}

bool stimulating(const std::string& outcome) {
    return outcome == "delivered" || outcome == "priority" || outcome == "auxiliary";
}

}  // namespace

WarmUp::WarmUp(const RecordedPort& port, const std::vector<std::string>& carriers,
               const std::vector<char>& stimulated)
    : settled_at_(-std::numeric_limits<double>::infinity()) {
    const double start = port.clock.started_clock;
    for (std::size_t c = 0; c < port.connections.size(); ++c) {
        const auto recorded = priority_of(port.connections[c].carrier);
        const auto re_run = priority_of(carriers[c]);
        if (!recorded && !re_run)
            continue;        // no stimulation: no past to forget
        double quiet = 0;    // the longest tc + tr of the two
        bool resets = true;  // every stimulation fixes the state (st >= 1, tr = 0)
        for (const auto& params : {recorded, re_run}) {
            if (!params)
                continue;
            quiet = std::max(quiet, params->tc + params->tr);
            resets = resets && params->st >= 1 && params->tr == 0;
        }
        // Walk the connection's stimulations in time order: the first that fixes the state in
        // both runs, or the first quiet spell, settles it.
        std::vector<std::pair<double, std::size_t>> times;
        for (std::size_t i = 0; i < port.messages.size(); ++i) {
            const auto& message = port.messages[i];
            if (message.connection != c || !message.decision)
                continue;
            const double at = message.decision->decision_time != 0 ? message.decision->decision_time
                                                                   : port.clock.clock_of(message.log_time);
            times.emplace_back(at, i);
        }
        std::sort(times.begin(), times.end());
        double previous = start;
        double settled = std::numeric_limits<double>::infinity();
        for (const auto& [at, i] : times) {
            const bool in_recording = !recorded || stimulating(port.messages[i].decision->outcome);
            const bool in_re_run = !re_run || stimulated[i];
            if (!in_recording && !in_re_run)
                continue;
            if (at - previous > quiet) {
                settled = previous + quiet;
                break;
            }
            if (resets && in_recording && in_re_run) {
                settled = at;
                break;
            }
            previous = at;
        }
        if (settled == std::numeric_limits<double>::infinity())
            settled = previous + quiet;
        settled_at_ = std::max(settled_at_, settled);
        // A connection with no message in the recording has no channel, so the re-run does not know
        // it: it may have been stimulated just before the start. As long as the slowest known one.
        settled_at_ = std::max(settled_at_, start + quiet);
    }
}

}  // namespace plexus::record
