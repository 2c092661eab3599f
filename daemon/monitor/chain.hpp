#pragma once
// Threading: as its monitors (monitor.hpp): process() under the stage's monitors lock, stats() from
// anywhere.

#include <memory>
#include <vector>

#include <nlohmann/json.hpp>

#include "monitor.hpp"

namespace plexus::daemon::monitor {

/// The monitors of one side of one connection, applied in the order the carrier lists them.
struct MonitorChain {
    std::vector<std::unique_ptr<Monitor>> monitors;

    /// False when a monitor dropped the message; `message` may have been rewritten on the way.
    bool process(Message& message) {
        for (auto& monitor : monitors) {
            if (monitor->process(message) == Monitor::Verdict::drop)
                return false;
        }
        return true;
    }

    /// The answer to a call, back through the monitors in the reverse order of its request.
    void reply(Message& message) {
        for (auto monitor = monitors.rbegin(); monitor != monitors.rend(); ++monitor)
            (*monitor)->reply(message);
    }
    bool has_reply() const {
        for (const auto& monitor : monitors) {
            if (monitor->has_reply())
                return true;
        }
        return false;
    }

    /// True when every monitor is a script: the sandbox looks at the clock while they run, so they
    /// may run inline on the daemon's thread (stage.hpp). A compiled monitor cannot be watched.
    bool interruptible() const {
        for (const auto& monitor : monitors) {
            if (monitor->spec().type != MonitorType::lua)
                return false;
        }
        return true;
    }

    nlohmann::json stats() const {
        auto list = nlohmann::json::array();
        for (const auto& monitor : monitors)
            list.push_back(monitor->stats());
        return list;
    }
};

}  // namespace plexus::daemon::monitor
