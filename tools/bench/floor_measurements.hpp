#pragma once
// The same scenarios on the floor: the same threads and traffic as plexus_measurements.hpp, through
// the relay(s) of relay.hpp instead of plexusd. Each side is a thread with its own Unix socket.

#include <memory>

#include "measurement.hpp"
#include "options.hpp"
#include "topology.hpp"

namespace plexus::bench {

/// Ping-pong through the relay(s): A writes a frame, B writes it back.
std::unique_ptr<Measurement> floor_latency(const Topology& topology, const Options& options);

/// Streaming through the relay(s): A writes frames batched up to 64 KiB per send; B reads them all.
std::unique_ptr<Measurement> floor_throughput(const Topology& topology, const Options& options);

}  // namespace plexus::bench
