#pragma once
// Threading: owned by the daemon's one thread; no locking.

#include <cstdint>
#include <memory>
#include <string>

#include "message.hpp"

namespace plexus::daemon {

namespace monitor {
struct MonitorChain;
}

/// Where a connection delivers: a port of this daemon, or a link to another daemon.
class MessageSink {
public:
    virtual ~MessageSink() = default;
    /// True while a writer must wait before sending more (strict back-pressure).
    virtual bool full() const = 0;
    /// How many more messages it takes before it is full (a batch is cut to fit).
    virtual std::size_t room() const = 0;
    virtual void deliver(const Message& message) = 0;
    /// The connection is going away: send what is queued, then let go.
    virtual void close_after_flush() {}
};

/// A directed connection out of a port of this daemon.
struct Connection {
    std::string source;
    std::string destination;
    std::string carrier;  ///< canonical carrier text
    bool remote = false;  ///< true when the destination lives on another daemon (or the carrier forces tcp)
    int priority = 0;     ///< qos.prio: its port hands each message to higher ones first (Router::add)
    std::shared_ptr<MessageSink> sink;
    std::shared_ptr<monitor::MonitorChain> send_chain;  ///< send-side monitors; null when there are none
    std::uint64_t sent = 0;                             ///< messages written into the source
    std::uint64_t dropped_by_monitor = 0;               ///< dropped by a send-side monitor
};

}  // namespace plexus::daemon
