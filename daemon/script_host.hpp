#pragma once
// Threading: the daemon's one thread.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/router.hpp"
#include "monitor/chain.hpp"
#include "monitor/monitor.hpp"
#include "net/asio.hpp"
#include "plexus/proto/carrier.hpp"

namespace plexus::daemon {

class Daemon;

/// What the daemon gives monitor scripts: trig timers on the event loop, ports they publish on,
/// the clock. Also builds the monitor chains of a carrier string.
class ScriptHost : public monitor::MonitorHost {
public:
    ScriptHost(asio::io_context& io, Daemon& daemon);
    ~ScriptHost() override;

    /// The monitors of one side of a connection, created in carrier order. Fails (and creates
    /// nothing) when a script is missing, does not load, or refuses; null when the side has none.
    /// Recv-side monitors take part in the arbitration through `member`.
    proto::Result<std::shared_ptr<monitor::MonitorChain>> build_chain(
        const proto::Carrier& carrier, proto::Side side, const std::string& source,
        const std::string& destination, const std::shared_ptr<arbitration::Member>& member = nullptr);

    proto::Status publish(monitor::Monitor& monitor, const std::string& port,
                          const nlohmann::json& value) override;
    void set_trig_interval(monitor::Monitor& monitor, double seconds) override;
    double now() const override;
    void monitor_gone(monitor::Monitor& monitor) override;

    std::uint64_t published() const { return published_; }
    std::uint64_t publish_dropped() const { return publish_dropped_; }

private:
    struct Trig {
        monitor::Monitor* monitor = nullptr;
        std::unique_ptr<asio::steady_timer> timer;
        std::chrono::steady_clock::duration period{};
        std::uint64_t generation = 0;
    };
    void arm(std::uint64_t monitor_id);

    asio::io_context& io_;
    Daemon& daemon_;
    std::map<std::uint64_t, Trig> trigs_;                                ///< by monitor id
    std::map<std::uint64_t, std::vector<std::shared_ptr<Port>>> ports_;  ///< published, by monitor id
    std::map<std::string, std::uint64_t> port_seq_;
    std::uint64_t next_generation_ = 1;
    int publish_depth_ = 0;  ///< publish -> monitor -> publish ... is cut off past a few levels
    std::uint64_t published_ = 0;
    std::uint64_t publish_dropped_ = 0;
};

}  // namespace plexus::daemon
