#pragma once
// Threading: the daemon's one thread, except the MonitorHost functions, which monitors call on their
// workers: those only check their arguments there and post the rest to the daemon's thread.

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "control/monitor_wiring.hpp"
#include "core/router.hpp"
#include "monitor/chain.hpp"
#include "monitor/monitor.hpp"
#include "monitor/stage.hpp"
#include "monitor/workers.hpp"
#include "net/asio.hpp"
#include "plexus/proto/carrier.hpp"

namespace plexus::daemon {

class Daemon;

/// What the daemon gives monitor scripts: trig timers on the event loop, ports they publish on,
/// the clock. Also builds the monitor chains of a carrier string.
class ScriptHost : public monitor::MonitorHost, public MonitorWiring {
public:
    ScriptHost(asio::io_context& io, Daemon& daemon, std::shared_ptr<monitor::Workers> workers);
    ~ScriptHost() override;

    // --- MonitorWiring, for the control plane ---
    proto::Result<std::shared_ptr<monitor::MonitorChain>> build_chain(
        const proto::Carrier& carrier, proto::Side side, const std::string& source,
        const std::string& destination,
        const std::shared_ptr<arbitration::Member>& member = nullptr) override;
    std::shared_ptr<monitor::MonitorStage> make_stage(std::shared_ptr<monitor::MonitorChain> chain,
                                                      std::shared_ptr<arbitration::Member> member,
                                                      monitor::MonitorStage::Options options,
                                                      std::weak_ptr<FilterClient> client) override;
    std::uint64_t published() const override { return published_; }
    std::uint64_t publish_dropped() const override { return publish_dropped_; }

    // --- monitor::MonitorHost, for the monitors ---
    proto::Status publish(monitor::Monitor& monitor, const std::string& port,
                          const nlohmann::json& value) override;
    void set_trig_interval(monitor::Monitor& monitor, double seconds) override;
    double now() const override;
    void monitor_gone(monitor::Monitor& monitor) override;

    /// Messages still in any monitors (shutdown waits a little for them).
    std::size_t in_flight() const;
    /// Shutdown: every stage lets its monitors go and drops what waits, so that no script, however
    /// slow, holds the daemon past its grace.
    void close_stages();

private:
    struct Trig {
        std::weak_ptr<monitor::MonitorStage> stage;  ///< where the monitor runs
        std::unique_ptr<asio::steady_timer> timer;
        std::chrono::steady_clock::duration period{};
        std::uint64_t generation = 0;
    };
    void arm(std::uint64_t monitor_id);
    // The daemon's-thread halves of the MonitorHost functions.
    void start_trig(std::uint64_t monitor_id, double seconds);
    void publish_now(std::uint64_t monitor_id, const std::string& description, const std::string& port,
                     const nlohmann::json& value, int depth);
    void forget_monitor(std::uint64_t monitor_id);

    asio::io_context& io_;
    Daemon& daemon_;
    std::shared_ptr<monitor::Workers> workers_;
    std::map<std::uint64_t, std::weak_ptr<monitor::MonitorStage>> stages_;  ///< by monitor id
    std::map<std::uint64_t, Trig> trigs_;                                   ///< by monitor id
    std::map<std::uint64_t, std::vector<std::shared_ptr<Port>>> ports_;     ///< published, by monitor id
    std::map<std::string, std::uint64_t> port_seq_;
    std::uint64_t next_generation_ = 1;
    std::uint64_t published_ = 0;
    std::uint64_t publish_dropped_ = 0;
};

}  // namespace plexus::daemon
