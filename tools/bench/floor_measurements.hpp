#pragma once
// The same scenarios on the floor: the same threads and traffic as plexus_measurements.hpp, through
// the relay(s) of relay.hpp instead of plexusd. Each side is a thread with its own Unix socket.

#include <sys/types.h>

#include <memory>
#include <vector>

#include "floor_socket.hpp"
#include "measurement.hpp"
#include "options.hpp"
#include "topology.hpp"

namespace plexus::bench {

/// The two ends a floor scenario uses, however they are joined: A (writes, pings) and B (reads,
/// echoes), and the processes between them whose CPU is the cost (none for a direct connection).
struct FloorEnds {
    std::unique_ptr<FloorSocket> near;
    std::unique_ptr<FloorSocket> far;
    std::vector<pid_t> pids;
};

/// Ping-pong through the relay(s): A writes a frame, B writes it back.
std::unique_ptr<Measurement> floor_latency(const Topology& topology, const Options& options);

/// The floor of a call: the same ping-pong (A's request through the relay(s) to B, B's answer back
/// the same way), timed as the whole round trip, as a caller waits for it.
std::unique_ptr<Measurement> floor_round_trip(const Topology& topology, const Options& options);

/// Streaming through the relay(s): A writes frames batched up to 64 KiB per send; B reads them all.
std::unique_ptr<Measurement> floor_throughput(const Topology& topology, const Options& options);

/// The same two scenarios between given ends (a direct TCP connection across hosts).
std::unique_ptr<Measurement> floor_latency_between(FloorEnds ends, const Options& options);
std::unique_ptr<Measurement> floor_throughput_between(FloorEnds ends, const Options& options);
std::unique_ptr<Measurement> floor_round_trip_between(FloorEnds ends, const Options& options);

}  // namespace plexus::bench
