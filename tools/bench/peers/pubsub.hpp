#pragma once
// What `plexus-bench peers` needs of a broker: start its server(s), and publish and subscribe on a
// topic through its own C/C++ client library. Every system (Plexus, Mosquitto, NATS, ZeroMQ,
// Redis) implements these three classes; the scenarios (peer_scenarios.hpp) are written once,
// against them, so every system does exactly the same job.
//
// Threading: each Publisher and Subscriber is its own client connection and is used by one
// thread at a time (it may be created on another thread than the one that uses it). The Broker
// is used only by the thread that runs the scenario.

#include <sys/types.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "../child_process.hpp"

namespace plexus::bench::peers {

/// Sends messages on one topic.
class Publisher {
public:
    virtual ~Publisher() = default;
    /// Sends one message. May buffer inside the client library, but must make progress by itself
    /// (a publisher that is never synced still delivers everything eventually).
    virtual void publish(std::string_view payload) = 0;
    /// Waits until everything published so far has left this client (and, where the protocol
    /// answers each publish, until the answers are read). Called outside the timed path.
    virtual void sync() {}
};

/// Receives the messages of one topic.
class Subscriber {
public:
    virtual ~Subscriber() = default;
    /// Waits up to `timeout` for the next message; false on timeout. Throws if the connection
    /// is lost (e.g. the server dropped a slow consumer).
    virtual bool receive(std::string& payload, std::chrono::milliseconds timeout) = 0;
};

/// Asks a service and waits for its answer (request/reply: NATS requests, Plexus calls).
class Requester {
public:
    virtual ~Requester() = default;
    /// Sends `payload` and waits up to `timeout` for the answer; false when none came in time.
    virtual bool request(std::string_view payload, std::string& answer,
                         std::chrono::milliseconds timeout) = 0;
};

/// Answers every request of a service with the request itself, from the library's own threads,
/// until destroyed.
class Responder {
public:
    virtual ~Responder() = default;
};

/// What a publisher is for, so that a client library with a documented faster mode for one of
/// them can use it (nats.c: "send ASAP" for latency instead of its flusher thread's batching).
enum class Traffic {
    latency,  ///< one message at a time, each wanted at the other end as soon as possible
    bulk,     ///< as many messages as possible
};

/// One running system: its server processes and a factory of clients.
class Broker {
public:
    virtual ~Broker() = default;
    /// The server processes whose CPU time and peak memory are measured.
    virtual std::vector<pid_t> pids() const = 0;
    /// A new client that publishes on `topic`.
    virtual std::unique_ptr<Publisher> publisher(const std::string& topic, Traffic traffic) = 0;
    /// A new client subscribed to `topic`. Messages published before the subscription took
    /// effect may be missed (the scenarios warm up until a message gets through).
    virtual std::unique_ptr<Subscriber> subscriber(const std::string& topic) = 0;
    /// Request/reply on `service`, for the systems that have it (null otherwise: the
    /// requestreply scenario then fails for that system, saying so). The responder first.
    virtual std::unique_ptr<Responder> responder(const std::string& service) {
        (void)service;
        return nullptr;
    }
    virtual std::unique_ptr<Requester> requester(const std::string& service) {
        (void)service;
        return nullptr;
    }
};

/// Where a system's programs are and where it may write its files.
struct BrokerSetup {
    const TempDir& dir;   ///< configuration files, sockets, logs
    std::string plexusd;  ///< the plexusd binary (Plexus only)
    std::string self;     ///< this program, for helper processes (the ZeroMQ proxy)
};

/// A system the bench can measure: its JSON `system` name, and how to start it.
struct System {
    std::string name;
    std::function<std::unique_ptr<Broker>(const BrokerSetup&)> start;
};

/// Every system built into this bench, Plexus first. The peers are there only when the bench was
/// configured with -DPLEXUS_BENCH_PEERS=ON (scripts/bench-peers-setup).
std::vector<System> all_systems();
/// True when the peers' drivers are built in.
bool peers_built();

}  // namespace plexus::bench::peers
