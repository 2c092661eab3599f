#pragma once
// The scenarios on Plexus, through the public client library only.
//
// Each side of a scenario is its own thread with its own plexus::Client (its own Unix socket to
// its daemon), in this one process: A on the first daemon, B on the last.

#include <functional>
#include <memory>
#include <string>

#include "plexus/client.hpp"

#include "measurement.hpp"
#include "options.hpp"
#include "topology.hpp"

namespace plexus::bench {

/// A detection-like map of about `size` CBOR bytes: {"c": 0.9, "pad": "xx..."}.
Value detection(std::size_t size);
/// Throws unless `message` is such a map (a monitor or arbitration let through what it should not).
void check_detection(const Received& message);

/// A client of the daemon at `socket`.
Client connect_client(const std::string& socket);
/// Registration with the name server may lag behind open(): waits until both ends are known.
void connect_when_registered(Client& client, const std::string& source, const std::string& destination,
                             const std::string& carrier = "");

/// Ping-pong: A writes /bench/ping -> B's /bench/pong-in; B echoes on /bench/pong -> A's /bench/ping-in.
/// With options.carrier, over that carrier and with the carrier in the names (/bench/udp-ping).
std::unique_ptr<Measurement> plexus_latency(const Topology& topology, const Options& options);

/// Calls: A's /bench/caller, connected to /bench/served that B serves (Client::serve, answering
/// with the request), calls it one call at a time with a blob of --size bytes; the figures are the
/// whole round trip. With options.carrier, over that carrier (/bench/tcp-caller).
std::unique_ptr<Measurement> plexus_calls(const Topology& topology, const Options& options);

/// Streaming: A writes /bench/source (batched) -> B's /bench/sink (strict queue); B reads all.
/// With options.carrier, over that carrier (/bench/udp-source); udp and mcast streams are lossy.
std::unique_ptr<Measurement> plexus_throughput(const Topology& topology, const Options& options);

/// What one stream carries and how: plexus_throughput is a blob of --size bytes over the default
/// carrier; the monitor scenario streams maps through carriers with monitors.
struct StreamSpec {
    std::string name;  ///< port names are /bench/NAME-source and /bench/NAME-sink
    Value payload;
    std::string carrier;                         ///< "" for the daemon's default
    std::function<void(const Received&)> check;  ///< throws if a delivered message is wrong
    /// Called once the stream is connected, before the warm-up, with the writing client and the
    /// sink's name: opens and connects other ports (competitors); they stay open with the stream.
    std::function<std::vector<Port>(Client&, const std::string& sink)> prepare;
    /// Messages may be lost (udp, mcast): the reader takes what arrives, in order, until the last
    /// message or until nothing has come for a while; RunResult::lost says how many did not.
    bool lossy = false;
};
std::unique_ptr<Measurement> plexus_stream(const Topology& topology, const Options& options, StreamSpec spec);

}  // namespace plexus::bench
