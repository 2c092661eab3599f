#pragma once
// The subcommands: each starts what it needs, measures, prints, and stops everything again.

#include "options.hpp"

namespace plexus::bench {

/// Ping-pong latency on Plexus and on the floor, in the same run. Returns the exit status.
int run_latency(const Options& options);
/// Call round trips (request/reply, issue 29) on Plexus and on the floor with the same hops (the
/// ping-pong's, timed whole), in the same run.
int run_calls(const Options& options);
/// Streaming throughput on Plexus and on the floor, in the same run.
int run_throughput(const Options& options);
/// Resident memory of one plexusd, idle and with `options.ports` ports open.
int run_memory(const Options& options);
/// Resident memory of one plexusd before, at the peak of, and after a burst into stalled readers.
int run_memory_burst(const Options& options);
/// Single-thread memcpy rate for the payload size, warm and cold (memcpy_scenario.cpp).
int run_memcpy(const Options& options);
/// Throughput and daemon CPU with no monitor, a one-field accept and a rewriting update.
int run_monitor(const Options& options);
/// One-hop latency with and without a recv monitor, alternated run by run.
int run_monitor_latency(const Options& options);
/// Total throughput of 1, 2 and 4 independent monitored connections with a ~20 us script.
int run_monitor_scaling(const Options& options);
int run_streams(const Options& options);
/// Added CPU per message with 2, 4 and 8 competing connections (constraints, priority), and the
/// switch time back to a stream once a competitor's hold ends.
int run_arbitration(const Options& options);
/// One-hop latency and throughput without --http and with the web endpoint busy (idle connections
/// and a stream reader), alternated; then plexusd's CPU per second for the live stream with the
/// fetch robot running (web_scenario.cpp).
int run_web(const Options& options);
/// Recording (issue 28): its write rate against dd to the same directory; the data path without,
/// with and again without a recording; `plexus what-if` in recorded messages per second
/// (record_scenario.cpp).
int run_record(const Options& options);

}  // namespace plexus::bench
