#pragma once
// Threading: owned by the daemon's one thread; no locking.

#include <cstdint>
#include <memory>
#include <string>

#include "connection.hpp"
#include "port.hpp"

namespace plexus::daemon {

namespace monitor {
struct MonitorChain;
}

/// A connection as its destination port sees it, whether it comes from a port of this daemon or
/// from another daemon: where the recv-side monitors run, with the counters `plexus stats` shows.
/// Owned by the connection (local) or by the link session (remote); the port only watches it.
class Inlet : public MessageSink {
public:
    Inlet(std::shared_ptr<Port> port, std::string source, std::string carrier)
        : port_(std::move(port)), source_(std::move(source)), carrier_(std::move(carrier)) {}

    bool full() const override { return port_->full(); }
    /// Runs the recv chain, then hands what passes to the port's reader queue.
    void deliver(const Message& message) override;

    const std::shared_ptr<Port>& port() const { return port_; }
    const std::string& source() const { return source_; }
    const std::string& carrier() const { return carrier_; }

    std::shared_ptr<monitor::MonitorChain> chain;  ///< recv-side monitors; null when there are none

    std::uint64_t received = 0;            ///< messages that arrived on this connection
    std::uint64_t dropped_by_monitor = 0;  ///< dropped by a recv-side monitor
    std::uint64_t delivered = 0;           ///< handed to the port's reader queue

private:
    std::shared_ptr<Port> port_;
    std::string source_;
    std::string carrier_;
};

}  // namespace plexus::daemon
