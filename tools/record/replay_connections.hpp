#pragma once
// Used by one thread.
//
// A recorded port's connections rebuilt offline as the daemon builds them (control/wire_inlet.cpp):
// an Arbiter on a clock the re-run moves, one Member per connection configured from its carrier
// (arbitration/carrier_rules), its recv-side monitors (monitor/carrier_monitors), the weights
// checked, the members joined in the recorded connection order.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "arbitration/arbiter.hpp"
#include "arbitration/clock.hpp"
#include "monitor/chain.hpp"
#include "monitor/monitor.hpp"
#include "recorded_port.hpp"

namespace plexus::record {

/// What the daemon gives monitors, offline: the recorded clock, and nothing that reaches outside.
class ReplayHost final : public daemon::monitor::MonitorHost {
public:
    ReplayHost(const daemon::arbitration::ManualClock& clock, RecordingClock note)
        : clock_(clock), note_(note) {}
    /// Nothing is published offline: counted, so the report can say so.
    proto::Status publish(daemon::monitor::Monitor&, const std::string&, const nlohmann::json&) override {
        ++publishes_;
        return proto::Ok{};
    }
    /// The daemon calls trig() from a timer whose firings the recording does not hold: noted only.
    void set_trig_interval(daemon::monitor::Monitor&, double seconds) override { trig_asked_ |= seconds > 0; }
    /// Unix seconds, as the daemon's host gives, at the recorded instant.
    double now() const override { return note_.unix_seconds_of(clock_.now()); }
    void monitor_gone(daemon::monitor::Monitor&) override {}

    std::uint64_t publishes() const { return publishes_; }
    bool trig_asked() const { return trig_asked_; }

private:
    const daemon::arbitration::ManualClock& clock_;
    RecordingClock note_;
    std::uint64_t publishes_ = 0;
    bool trig_asked_ = false;
};

/// One connection as re-run.
struct ReplayConnection {
    std::string source;
    std::string carrier;  ///< as re-run
    std::shared_ptr<daemon::arbitration::Member> member;
    std::shared_ptr<daemon::monitor::MonitorChain> monitors;  ///< null: none
};

/// The port's arbitration and monitors, offline. Members and monitors go before the host and
/// the arbiter they use (declaration order below).
class ReplayConnections {
public:
    struct Places {
        std::vector<std::string> script_dirs;
        std::vector<std::string> monitor_lib_dirs;
        daemon::monitor::MonitorPolicy policy;
    };
    /// `carriers[i]` is the carrier connection i of `port` runs with. The monitors' create() runs
    /// at the recording's start on the clock. Errors name the connection.
    static proto::Result<std::unique_ptr<ReplayConnections>> build(const RecordedPort& port,
                                                                   const std::vector<std::string>& carriers,
                                                                   const Places& places);
    ~ReplayConnections();

    daemon::arbitration::ManualClock& clock() { return clock_; }
    daemon::arbitration::Arbiter& arbiter() { return *arbiter_; }
    std::vector<ReplayConnection>& connections() { return connections_; }
    const ReplayHost& host() const { return host_; }
    /// Failed callbacks of every monitor so far.
    std::uint64_t script_errors() const;

private:
    explicit ReplayConnections(const RecordedPort& port);

    daemon::arbitration::ManualClock clock_;
    ReplayHost host_;
    std::shared_ptr<daemon::arbitration::Arbiter> arbiter_;
    std::vector<ReplayConnection> connections_;
};

}  // namespace plexus::record
