#pragma once
// The jobs every system of `plexus-bench peers` does, written once against pubsub.hpp.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "pubsub.hpp"

namespace plexus::bench::peers {

enum class Scenario {
    pingpong,      ///< request on one topic, answer on another, one at a time: p50/p99 of round trip / 2
    rate_1khz,     ///< one publisher at a fixed 1 kHz, one subscriber: one-way latency p50/p99/p99.9
    throughput,    ///< one publisher as fast as it can, one subscriber: messages/s at the subscriber
    fanout_8,      ///< one publisher as fast as it can, 8 subscribers: deliveries/s, the last one's p99
    requestreply,  ///< a request and its answer through the system's own request/reply, one at a
                   ///< time: p50/p99 of the whole round trip (not halved); only when asked for
};

/// The scenarios run when none is named (pub/sub: every system has it).
const std::vector<Scenario>& all_scenarios();
/// Those and the ones only some systems have (requestreply: Plexus calls, NATS requests).
const std::vector<Scenario>& known_scenarios();
/// The JSON `scenario` name: "pingpong", "rate_1khz", "throughput", "fanout_8", "requestreply".
std::string name_of(Scenario scenario);

/// The figures of one run (or the medians of several) of one system.
struct PeerResult {
    double p50_us = 0;
    double p99_us = 0;
    double p999_us = 0;
    double msgs_per_s = 0;      ///< messages received by subscribers per second (all subscribers together)
    double mb_per_s = 0;        ///< their payload, 10^6 bytes per second
    double lost = 0;            ///< messages published and never received (summed over subscribers)
    double cpu_us_per_msg = 0;  ///< server CPU time per message received
    double rss_mb = 0;          ///< peak resident memory of the server processes at the end of the run
    std::string warning;        ///< something a reader of the figures must know (a lost connection)
};

/// How much one run sends.
struct Workload {
    std::size_t size = 64;  ///< bytes per message, at least min_message_size
    std::size_t count = 0;  ///< round trips (pingpong) or messages published
};

/// Runs one scenario once on a freshly started broker. Throws if the system cannot do the job
/// (e.g. a ping-pong message is lost, which would leave the round trip waiting forever).
PeerResult run_scenario(Scenario scenario, Broker& broker, const Workload& workload);

/// Messages per run for a scenario and size: about the same bytes for every size, with floors so
/// that large messages still give enough samples. `quick` divides by ten (smoke runs).
std::size_t default_count(Scenario scenario, std::size_t size, bool quick);

}  // namespace plexus::bench::peers
