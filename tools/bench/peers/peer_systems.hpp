#pragma once
// The peers `plexus-bench peers` compares Plexus with, each through its own server and C client library
// (Debian 12 packages, installed by scripts/bench-peers-setup). Every one runs on 127.0.0.1 with
// nothing persistent, and publishes and subscribes without acknowledgements (fire and forget).

#include <string>

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

/// Body of the `zmq-proxy --ready-file FILE` helper process: binds, writes its endpoints to FILE, forwards
/// until killed. Returns an exit status only when it fails.
int run_zmq_proxy(const std::string& ready_file);

}  // namespace plexus::bench::peers
