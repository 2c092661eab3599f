#pragma once
// The peers `plexus-bench peers` compares Plexus with, each through its own server and C client library
// (Debian 12 packages, installed by scripts/bench-peers-setup). The brokers run on 127.0.0.1 with
// nothing persistent, and publish and subscribe without acknowledgements (fire and forget). The
// brokerless systems (Cyclone DDS, iceoryx) run each run in a process of their own, with the far end
// of each scenario in another (far_end.hpp); their drivers' opening comments list their choices.

#include <string>

#include "far_end.hpp"
#include "pubsub.hpp"

namespace plexus::bench::peers {

/// Mosquitto (MQTT 3.1.1, QoS 0) through libmosquitto, one connection per client.
System mosquitto_system();

/// nats-server through nats.c (core NATS, no JetStream), one connection per client.
System nats_system();

/// ZeroMQ PUB → XSUB/XPUB proxy process → SUB, over TCP, the proxy being the broker.
System zeromq_system();

/// Redis pub/sub through hiredis, one connection per client.
System redis_system();

/// Cyclone DDS, reliable (ROS 2's default QoS), over UDP in a network namespace of the run's own.
System cyclonedds_system();

/// Cyclone DDS, best effort, otherwise the same.
System cyclonedds_best_effort_system();

/// iceoryx: loaned shared-memory chunks through a RouDi of the run's own.
System iceoryx_system();

/// Body of the `peer-far-end` helper process of DDS and iceoryx: subscribes and reports, or
/// echoes, until SIGTERM. Returns the exit status.
int run_far_end(const FarEndOptions& options);
int run_cyclonedds_far_end(const FarEndOptions& options);
int run_iceoryx_far_end(const FarEndOptions& options);

/// Body of the `zmq-proxy --ready-file FILE` helper process: binds, writes its endpoints to FILE, forwards
/// until killed. Returns an exit status only when it fails.
int run_zmq_proxy(const std::string& ready_file);

}  // namespace plexus::bench::peers
