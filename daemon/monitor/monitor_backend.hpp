#pragma once
// Threading: as its Monitor's (one thread at a time).
//
// What runs a monitor's callbacks: a Lua script (lua_monitor.hpp) or a compiled plugin
// (plugin_monitor.hpp). The Monitor shell around it counts, applies the failure policy and
// quarantines; a backend only calls the code and says how the call went.

#include <cstddef>
#include <optional>

#include <nlohmann/json.hpp>

#include "../core/message.hpp"
#include "lua_sandbox.hpp"

namespace plexus::daemon::monitor {

class MonitorBackend {
public:
    virtual ~MonitorBackend() = default;

    /// How accept and update went on one message.
    struct Outcome {
        std::optional<ScriptError> error;
        bool in_accept = false;  ///< the error came from accept (else from update)
        bool accepted = true;
        bool rewritten = false;  ///< the message was replaced
    };

    virtual bool has_accept() const = 0;
    virtual bool has_update() const = 0;
    /// accept, then update on an accepted message; `message` may be replaced when it passes.
    virtual Outcome process(Message& message) = 0;
    /// PortMonitor.reply on the answer to a call that passed this connection (request/reply):
    /// `message` may be replaced; `accepted` is not used. A backend without it has none.
    virtual bool has_reply() const { return false; }
    virtual Outcome reply(Message& message) {
        (void)message;
        return {};
    }
    virtual std::optional<ScriptError> trig() = 0;
    /// `result` stays null when there is no getparam.
    virtual std::optional<ScriptError> getparam(nlohmann::json& result) = 0;
    /// `defined` false when there is no setparam.
    virtual std::optional<ScriptError> setparam(const nlohmann::json& values, bool& defined) = 0;
    /// The destroy callback, when the connection goes away (not on quarantine).
    virtual std::optional<ScriptError> destroy() = 0;
    /// Bytes the backend knows it holds (a Lua state's); 0 when it cannot know (a plugin's).
    virtual std::size_t memory_in_use() const = 0;
};

}  // namespace plexus::daemon::monitor
