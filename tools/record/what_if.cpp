#include "what_if.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <mutex>
#include <optional>

#include "arbitration/stimulation.hpp"
#include "core/message.hpp"
#include "plexus/proto/carrier.hpp"
#include "plexus/proto/message.hpp"
#include "replay_connections.hpp"
#include "warm_up.hpp"

namespace plexus::record {

namespace arbitration = daemon::arbitration;

namespace {

const char* outcome_name(arbitration::Arbiter::Verdict verdict) {
    switch (verdict) {
        case arbitration::Arbiter::Verdict::constraint:
            return "constraint";
        case arbitration::Arbiter::Verdict::priority:
            return "priority";
        case arbitration::Arbiter::Verdict::auxiliary:
            return "auxiliary";
        case arbitration::Arbiter::Verdict::deliver:
            break;
    }
    return "delivered";
}

/// One half of a message's passage through the port.
struct Step {
    double time = 0;
    std::size_t message = 0;
    bool decide = false;  ///< false: its monitors; true: its arbitration
};

/// The record a monitor sees, rebuilt from what was recorded (payload exactly as sent).
daemon::Message message_for(const RecordedMessage& recorded, const std::string& source) {
    proto::Bytes bytes;
    proto::append_record(bytes, source, recorded.seq, recorded.publish_time, recorded.payload);
    auto chunk = std::make_shared<daemon::Chunk>(bytes.size());
    std::memcpy(chunk->data(), bytes.data(), bytes.size());
    const proto::ByteView view(chunk->data(), bytes.size());
    return daemon::Message{std::move(chunk), view, recorded.seq};
}

/// The two instants of a recorded message on the arbitration clock; an unknown one (0) is its
/// arrival, and the monitors never start after the decision.
std::pair<double, double> instants(const RecordedMessage& message, const RecordingClock& clock) {
    const double arrival = clock.clock_of(message.log_time);
    double decided = message.decision->decision_time != 0 ? message.decision->decision_time : arrival;
    double monitored = message.decision->monitor_time != 0 ? message.decision->monitor_time : decided;
    return {std::min(monitored, decided), decided};
}

/// Switches of the delivering source along `delivered` (non-auxiliary deliveries, in order).
std::uint64_t switches(const std::vector<std::size_t>& delivered) {
    std::uint64_t count = 0;
    for (std::size_t i = 1; i < delivered.size(); ++i)
        count += delivered[i] != delivered[i - 1] ? 1 : 0;
    return count;
}

/// One re-run of the port with `carriers`: each decided message's outcome.
struct Run {
    std::vector<std::string> outcomes;        ///< per message; "" when it was not re-run
    std::vector<char> stimulated;             ///< per message: it reached its connection's stimulation
    std::vector<std::size_t> decision_order;  ///< messages in the order they were decided
    std::uint64_t script_errors = 0;
    std::uint64_t publishes = 0;
    bool trig_asked = false;
};

proto::Result<Run> run_port(const RecordedPort& port, const std::vector<std::string>& carriers,
                            const WhatIfOptions& options) {
    auto built = ReplayConnections::build(port, carriers,
                                          {options.script_dirs, options.monitor_lib_dirs, options.policy});
    if (!built)
        return built.error();
    ReplayConnections& replay = **built;
    Run run;

    // Every step of every decided message, in time order; ties keep file order, a message's
    // monitors before its arbitration.
    const std::size_t n = port.messages.size();
    std::vector<Step> steps;
    steps.reserve(2 * n);
    for (std::size_t i = 0; i < n; ++i) {
        if (!port.messages[i].decision)
            continue;  // it never reached the arbitration live: re-running it would change the state
        const auto [monitored, decided] = instants(port.messages[i], port.clock);
        steps.push_back({monitored, i, false});
        steps.push_back({decided, i, true});
    }
    std::stable_sort(steps.begin(), steps.end(),
                     [](const Step& a, const Step& b) { return a.time < b.time; });

    std::vector<char> passed(n, 0);
    auto& outcomes = run.outcomes;
    auto& stimulated = run.stimulated;
    auto& decision_order = run.decision_order;
    outcomes.resize(n);
    stimulated.assign(n, 0);
    auto& clock = replay.clock();
    for (const Step& step : steps) {
        clock.set(std::max(clock.now(), step.time));  // the recorded clock never went backwards
        const RecordedMessage& recorded = port.messages[step.message];
        auto& connection = replay.connections()[recorded.connection];
        if (!step.decide) {
            if (!connection.monitors) {
                passed[step.message] = 1;
                continue;
            }
            auto message = message_for(recorded, connection.source);
            passed[step.message] = connection.monitors->process(message) ? 1 : 0;
            continue;
        }
        decision_order.push_back(step.message);
        auto& member = *connection.member;
        if (!passed[step.message]) {
            outcomes[step.message] = "accept";
            continue;
        }
        if (member.trivial()) {
            outcomes[step.message] = "delivered";
            continue;
        }
        auto& arbiter = replay.arbiter();
        std::lock_guard lock(arbiter.mutex());
        const bool constraint_holds = arbiter.constraint_value(member, clock.now());
        outcomes[step.message] = outcome_name(arbiter.admit(member, clock.now()));
        stimulated[step.message] = constraint_holds && member.stimulus ? 1 : 0;
    }

    run.script_errors = replay.script_errors();
    run.publishes = replay.host().publishes();
    run.trig_asked = replay.host().trig_asked();
    return run;
}

}  // namespace

bool needs_payloads(const std::string& carrier_text) {
    auto carrier = proto::parse_carrier(carrier_text);
    if (!carrier)
        return true;  // the re-run reports the error; reading payloads changes nothing
    return std::any_of(carrier->clauses.begin(), carrier->clauses.end(), [](const proto::Clause& clause) {
        return clause.side == proto::Side::recv && clause.modifier == "portmonitor" && clause.find("file");
    });
}

proto::Result<WhatIfResult> what_if(const RecordedPort& port, const WhatIfOptions& options) {
    // Which carrier each connection runs with.
    std::vector<std::string> carriers;
    for (const auto& connection : port.connections) {
        const auto replaced = options.carriers.find(connection.source);
        carriers.push_back(replaced != options.carriers.end() ? replaced->second : connection.carrier);
    }
    for (const auto& [source, carrier] : options.carriers) {
        const bool known = std::any_of(port.connections.begin(), port.connections.end(),
                                       [&](const RecordedConnection& c) { return c.source == source; });
        if (!known) {
            std::string sources;
            for (const auto& connection : port.connections)
                sources += (sources.empty() ? "" : ", ") + connection.source;
            return proto::Error{"--carrier " + source + "=...: the recording has no connection from " +
                                source + " into " + port.port + " (it has " + sources + ")"};
        }
    }
    auto run = run_port(port, carriers, options);
    if (!run)
        return run.error();
    const auto& outcomes = run->outcomes;
    // The recorded carriers' own re-run, when some were replaced: in the warm-up, a message that
    // it does not reproduce was decided by the unrecorded past, and is not compared.
    std::vector<std::string> recorded_carriers;
    for (const auto& connection : port.connections)
        recorded_carriers.push_back(connection.carrier);
    std::optional<proto::Result<Run>> baseline_run;
    if (recorded_carriers != carriers) {
        baseline_run.emplace(run_port(port, recorded_carriers, options));
        if (!*baseline_run)
            return (*baseline_run).error();
    }
    const auto& baseline = baseline_run ? (**baseline_run).outcomes : outcomes;

    // Which decisions could still depend on stimulation from before the recording began.
    const WarmUp warm_up(port, carriers, run->stimulated);

    const std::size_t n = port.messages.size();
    WhatIfResult result;
    result.decisions.resize(n);
    for (std::size_t i = 0; i < port.connections.size(); ++i) {
        SourceSummary summary;
        summary.source = port.connections[i].source;
        summary.carrier = carriers[i];
        summary.replaced = carriers[i] != port.connections[i].carrier;
        result.sources.push_back(std::move(summary));
    }
    double last = port.clock.started_clock;
    for (std::size_t i = 0; i < n; ++i) {
        const RecordedMessage& recorded = port.messages[i];
        MessageDecision& decision = result.decisions[i];
        decision.message = i;
        decision.source = port.connections[recorded.connection].source;
        decision.seq = recorded.seq;
        if (!recorded.decision) {
            decision.standing = Standing::undecided;
            decision.time = port.clock.clock_of(recorded.log_time) - port.clock.started_clock;
            ++result.undecided;
            continue;
        }
        const double decided = instants(recorded, port.clock).second;
        last = std::max(last, decided);
        decision.time = decided - port.clock.started_clock;
        decision.recorded = recorded.decision->outcome;
        decision.what_if = outcomes[i];
        if (warm_up.unsettled(decided) && baseline[i] != decision.recorded) {
            decision.standing = Standing::warm_up;
            ++result.warm_up;
            continue;
        }
        auto& summary = result.sources[recorded.connection];
        ++result.compared;
        ++summary.messages;
        summary.recorded_delivered += decision.recorded == "delivered" ? 1 : 0;
        summary.what_if_delivered += decision.what_if == "delivered" ? 1 : 0;
        if (decision.changed()) {
            ++result.changed;
            ++summary.changed;
        }
    }
    std::vector<std::size_t> recorded_winners;
    std::vector<std::size_t> what_if_winners;
    for (const std::size_t i : run->decision_order) {
        const auto& decision = result.decisions[i];
        if (decision.standing != Standing::compared)
            continue;
        if (decision.recorded == "delivered")
            recorded_winners.push_back(port.messages[i].connection);
        if (decision.what_if == "delivered")
            what_if_winners.push_back(port.messages[i].connection);
    }
    result.recorded_winner_changes = switches(recorded_winners);
    result.what_if_winner_changes = switches(what_if_winners);
    result.duration = last - port.clock.started_clock;
    result.script_errors = run->script_errors;
    result.publishes_ignored = run->publishes;
    result.trig_ignored = run->trig_asked;
    return result;
}

}  // namespace plexus::record
