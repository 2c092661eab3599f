#pragma once
// The floors of `plexus-bench hosts`: the least any program must do to move the same messages
// between two hosts over the same veth, with no broker at all. Both ends are threads of the bench
// whose sockets were made inside the hosts' namespaces (HostsNetwork::inside).
//
// - tcp: one TCP connection from host A to host B (TCP_NODELAY), carrying the frames of
//   floor_frame.hpp with FloorSocket's batching; the loops are floor_measurements.cpp's.
// - udp and mcast: datagrams of at most 1,400 payload bytes (plexusd's fragment size) with a
//   24-byte header (u64 seq, u64 send time, u32 fragment, u32 fragments), sent 64 per sendmmsg
//   (as plexusd does), unicast to B's address or to a multicast group B joined. Ping-pong echoes
//   every datagram back (to A's address, or to a group A joined); a stream is reassembled into
//   one buffer per message (a copy per fragment, as plexusd does) and may lose messages.

#include <memory>

#include "floor_measurements.hpp"
#include "hosts_network.hpp"
#include "measurement.hpp"
#include "options.hpp"

namespace plexus::bench {

/// A TCP connection from host `a` to host `b` (A's end is near, B's far); no broker processes.
FloorEnds tcp_floor_ends(const HostsNetwork& network, int a, int b);

/// Datagram ping-pong between hosts `a` and `b`: round trip / 2, like floor_latency.
std::unique_ptr<Measurement> datagram_floor_latency(const HostsNetwork& network, int a, int b, bool multicast,
                                                    const Options& options);

/// A stream of datagrams from host `a` to host `b`, blasted as fast as sendmmsg takes them; the
/// figures count the messages that arrived whole, RunResult::lost the others.
std::unique_ptr<Measurement> datagram_floor_throughput(const HostsNetwork& network, int a, int b,
                                                       bool multicast, const Options& options);

}  // namespace plexus::bench
