#pragma once
// Threading: the daemon's one thread.

#include <cstddef>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "arbitration/clock.hpp"
#include "control_config.hpp"
#include "monitor_wiring.hpp"
#include "net/carriers/carrier.hpp"
#include "net/daemon_counters.hpp"

namespace plexus::daemon {

class CallTable;

class Peer;
class Port;
class Router;
namespace names {
class NameClient;
}

/// What the control plane needs of the daemon, which implements it: the state the request handlers
/// read and the few things they ask the daemon to do. Narrow on purpose (like monitor::MonitorHost):
/// the handlers never see the daemon's listeners, its session table or its shutdown. It includes
/// what the carriers need (config(), udp(), mcast_group()), so the control plane hands it down
/// to them as their host (CarrierHost).
class ControlHost : public carriers::CarrierHost {
public:
    virtual ~ControlHost() = default;

    /// The settings the control plane reads (the carriers read their part, NetConfig).
    const ControlConfig& config() const override = 0;
    /// HOST:PORT of the daemon's TCP listener: where other daemons and the CLI reach it.
    virtual std::string address() const = 0;
    /// HOST:PORT of the web endpoint (--http); "" when it serves none.
    virtual std::string http_address() const = 0;
    /// True when the web endpoint speaks HTTPS (beyond loopback, with a secret).
    virtual bool http_tls() const { return false; }
    /// The SHA-256 of its self-signed certificate (the secret alone); empty otherwise.
    virtual std::string http_fingerprint() const { return {}; }
    /// The web endpoint's counters (web/http_counters.hpp), null when it serves none.
    virtual nlohmann::json http_counters() const = 0;
    virtual Router& router() = 0;
    virtual names::NameClient& names() = 0;
    /// Builds connections' monitor chains and puts them on stages (the daemon's script host).
    virtual MonitorWiring& scripts() = 0;
    /// Where arbitration reads the time (event lifetimes, stimulation decay).
    virtual const arbitration::Clock& clock() const = 0;
    /// The calling thread's counters, to count on.
    virtual DaemonCounters& counters() = 0;
    /// Every thread's counters added up, to show.
    virtual DaemonCounters total_counters() const = 0;
    /// The calls in progress through this daemon (request/reply).
    virtual CallTable& calls() = 0;
    /// Sessions open now.
    virtual std::size_t session_count() const = 0;
    /// True once the daemon is shutting down: a link that goes then is not reported as down.
    virtual bool stopping() const = 0;

    /// Wakes writers held back by a full strict queue (a connection went, so room may have come).
    virtual void notify_space() = 0;
    /// Closes a port of this daemon: its connections go, and the name server is told.
    virtual void forget_port(std::shared_ptr<Port> port) = 0;
    /// Keeps the sending end of a link in view, so that shutdown waits for it to flush.
    virtual void keep_link(std::weak_ptr<Peer> link) = 0;
};

}  // namespace plexus::daemon
