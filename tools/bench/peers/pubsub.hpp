#pragma once
// What `plexus-bench peers` needs of a broker: start its server(s), and publish and subscribe on a
// topic through its own C/C++ client library. Every system (Plexus, Mosquitto, NATS, ZeroMQ,
// Redis, Cyclone DDS, iceoryx) implements these classes; the scenarios (peer_scenarios.hpp) are
// written once, against them, so every system does exactly the same job.
//
// The brokerless systems (DDS, iceoryx) would hand a message from a publisher to a subscriber of
// the same process without their transport, so their Broker also gives the far end of a scenario
// (a stream's subscribers, a ping-pong's echo) in a process of its own: far_subscriber, far_echo.
//
// Threading: each Publisher and Subscriber is its own client connection and is used by one
// thread at a time (it may be created on another thread than the one that uses it). The Broker
// is used only by the thread that runs the scenario.

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "../child_process.hpp"
#include "stamp.hpp"

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
    /// A buffer of `size` bytes lent by the system, to be written in place and sent with
    /// publish_loan(); empty when the system lends none (then the scenario fills a message of its
    /// own and calls publish(), which copies it). Only iceoryx lends (its shared-memory chunks).
    virtual std::span<char> loan(std::size_t size) {
        (void)size;
        return {};
    }
    /// Sends the buffer the last loan() gave; it belongs to the system again.
    virtual void publish_loan() {}
};

/// What the scenarios read of a received message: its stamp, and when it arrived (steady clock).
struct Arrival {
    Stamp stamp{};
    std::int64_t arrived_ns = 0;
};

/// Receives the messages of one topic.
class Subscriber {
public:
    virtual ~Subscriber() = default;
    /// Waits up to `timeout` for the next message; false on timeout. Throws if the connection
    /// is lost (e.g. the server dropped a slow consumer).
    virtual bool receive(std::string& payload, std::chrono::milliseconds timeout) = 0;
    /// Waits like receive(), but gives only the message's stamp and its arrival time: all that the
    /// scenarios read. By default through receive() (a copy of the payload), arriving when it
    /// returns. iceoryx and DDS read the stamp where the library hands the message over, without
    /// copying the rest; a far subscriber reports when the message arrived in its own process.
    virtual bool receive_stamp(Arrival& arrival, std::chrono::milliseconds timeout) {
        if (!receive(payload_, timeout))
            return false;
        arrival.stamp = get_stamp(payload_);
        arrival.arrived_ns = steady_ns();
        return true;
    }

private:
    std::string payload_;  ///< receive_stamp's default: kept, so that its capacity is reused
};

/// Answers every message of one topic with a message of the same size and stamp on another, from
/// another process, until destroyed: the far end of a ping-pong.
class Echo {
public:
    virtual ~Echo() = default;
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
    /// A subscriber of `topic` in a process of its own, which reports what it receives: the
    /// subscribers of a stream, for the systems that must not deliver within one process. Null
    /// (the default): the scenario uses subscriber(), as a broker's clients meet in its process.
    virtual std::unique_ptr<Subscriber> far_subscriber(const std::string& topic) {
        (void)topic;
        return nullptr;
    }
    /// The same for a ping-pong's echo, from `from` to `to`. Null (the default): the scenario
    /// echoes on a thread of its own, through subscriber(from) and publisher(to).
    virtual std::unique_ptr<Echo> far_echo(const std::string& from, const std::string& to) {
        (void)from;
        (void)to;
        return nullptr;
    }
};

/// Where a system's programs are and where it may write its files.
struct BrokerSetup {
    const TempDir& dir;            ///< configuration files, sockets, logs
    std::string plexusd;           ///< the plexusd binary (Plexus only)
    std::string self;              ///< this program, for helper processes (the ZeroMQ proxy, far ends)
    std::size_t message_size = 0;  ///< bytes per message of the run (iceoryx sizes its chunks by it)
};

/// A system the bench can measure: its JSON `system` name, and how to start it.
struct System {
    std::string name;
    std::function<std::unique_ptr<Broker>(const BrokerSetup&)> start;
    /// Each run in a fresh process of its own (`plexus-bench peer-run`, own_process_run.hpp):
    /// iceoryx's runtime joins one RouDi per process lifetime, and a Cyclone DDS domain must be
    /// made inside the network namespace its run process enters.
    bool own_process = false;
};

/// Every system built into this bench, Plexus first. The peers are there only when the bench was
/// configured with -DPLEXUS_BENCH_PEERS=ON (scripts/bench-peers-setup).
std::vector<System> all_systems();
/// True when the peers' drivers are built in.
bool peers_built();

}  // namespace plexus::bench::peers
