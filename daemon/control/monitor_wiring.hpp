#pragma once
// Threading: the daemon's control thread.

#include <cstdint>
#include <memory>
#include <string>

#include "monitor/chain.hpp"
#include "monitor/stage.hpp"
#include "plexus/proto/bytes.hpp"
#include "plexus/proto/carrier.hpp"

namespace plexus::daemon {

/// What the control plane needs of the daemon's script host (app/script_host.hpp) to put monitors
/// on a connection: the chains of a carrier string, the stages they run on, and the counters of
/// what monitors published. An interface so that control/ does not see the daemon's application
/// layer (the script host also serves the monitors themselves, as their monitor::MonitorHost).
class MonitorWiring {
public:
    /// The monitors of one side of a connection, created in carrier order. Fails (and creates
    /// nothing) when a script is missing, does not load, or refuses; null when the side has none.
    /// Recv-side monitors take part in the arbitration through `member`.
    virtual proto::Result<std::shared_ptr<monitor::MonitorChain>> build_chain(
        const proto::Carrier& carrier, proto::Side side, const std::string& source,
        const std::string& destination, const std::shared_ptr<arbitration::Member>& member = nullptr) = 0;
    /// Puts a chain on a worker strand of its own: from here on its monitors run there. `member`
    /// (recv side) admits what they pass; `client` gets the verdicts.
    virtual std::shared_ptr<monitor::MonitorStage> make_stage(std::shared_ptr<monitor::MonitorChain> chain,
                                                              std::shared_ptr<arbitration::Member> member,
                                                              monitor::MonitorStage::Options options,
                                                              std::weak_ptr<FilterClient> client) = 0;
    /// Values monitors published on ports, and those dropped (`plexus stats`).
    virtual std::uint64_t published() const = 0;
    virtual std::uint64_t publish_dropped() const = 0;

protected:
    ~MonitorWiring() = default;
};

}  // namespace plexus::daemon
