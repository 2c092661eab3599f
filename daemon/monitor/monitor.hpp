#pragma once
// Threading: the daemon's one thread.
//
// One port monitor: a Lua script on one side of one connection, in its own sandboxed state. It
// sees each message (accept, update), runs on a timer (trig), answers `plexus param`, and is
// quarantined -- its state closed, its memory returned -- when it keeps failing.

#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "../arbitration/arbiter.hpp"
#include "../core/message.hpp"
#include "lua_sandbox.hpp"
#include "plexus/proto/carrier.hpp"
#include "script_library.hpp"

namespace plexus::daemon::monitor {

class Monitor;
struct MessageBox;

/// What the daemon gives scripts beyond the sandbox (DESIGN: "Functions the daemon gives the script").
class MonitorHost {
public:
    virtual ~MonitorHost() = default;
    /// Writes `value` on `port`, a port the daemon hosts for this monitor (opened on first use).
    virtual proto::Status publish(Monitor& monitor, const std::string& port, const nlohmann::json& value) = 0;
    /// Calls monitor.trig() every `seconds` from the event loop; 0 stops it.
    virtual void set_trig_interval(Monitor& monitor, double seconds) = 0;
    /// Seconds since the Unix epoch, from the daemon's clock.
    virtual double now() const = 0;
    /// The monitor is going away or was quarantined: stop its timers, close its ports.
    virtual void monitor_gone(Monitor& monitor) = 0;
};

/// What to do with a message when a callback fails. `by_callback`: accept errors drop, update
/// errors pass the original on (DESIGN); the clause key `onerror.drop|pass` forces one.
enum class OnError { by_callback, drop, pass };

struct MonitorSpec {
    Script script;
    proto::Side side = proto::Side::recv;
    std::string source;
    std::string destination;
    std::string carrier;
    std::map<std::string, std::string> options;  ///< the clause's keys that are not the monitor's own
    OnError on_error = OnError::by_callback;
    /// The connection's place in its input port's arbitration: setEvent, setConstraint... act on
    /// it. Recv side only; null on the send side, where those functions raise an error.
    std::shared_ptr<arbitration::Member> member;
};

struct MonitorPolicy {
    SandboxLimits limits;
    std::uint32_t quarantine_after = 5;  ///< consecutive failed calls
};

struct MonitorCounters {
    std::uint64_t messages = 0;   ///< messages the monitor saw
    std::uint64_t dropped = 0;    ///< by accept (or by a failure with the drop policy)
    std::uint64_t rewritten = 0;  ///< payloads replaced
    std::uint64_t errors = 0;     ///< failed calls of any callback, timeouts included
    std::uint64_t timeouts = 0;
    std::uint64_t out_of_memory = 0;
};

class Monitor {
public:
    /// Loads the script and calls create(options). Fails with the script's name and the Lua error
    /// (file and line), or when create returns false.
    static proto::Result<std::unique_ptr<Monitor>> create(MonitorSpec spec, const MonitorPolicy& policy,
                                                          MonitorHost& host);
    ~Monitor();
    Monitor(const Monitor&) = delete;
    Monitor& operator=(const Monitor&) = delete;

    enum class Verdict { pass, drop };
    /// Runs accept and update on a message; on pass, `message` may have been replaced.
    Verdict process(Message& message);
    void trig();
    /// getparam's table, or null when the script has no getparam.
    proto::Result<nlohmann::json> getparam();
    /// Calls setparam(values); false when the script has none.
    proto::Result<bool> setparam(const nlohmann::json& values);

    std::uint64_t id() const { return id_; }
    const MonitorSpec& spec() const { return spec_; }
    const MonitorCounters& counters() const { return counters_; }
    bool quarantined() const { return quarantined_; }
    const std::string& last_error() const { return last_error_; }
    std::size_t memory_in_use() const { return sandbox_ ? sandbox_->memory_in_use() : 0; }
    /// "certainty (recv)", for logs.
    std::string description() const;
    nlohmann::json stats() const;

private:
    Monitor(MonitorSpec spec, const MonitorPolicy& policy, MonitorHost& host);
    void install_api(lua_State* L);
    bool has_callback(lua_State* L, const char* name);
    /// Pushes PortMonitor[name] if it is a function; false (nothing pushed) otherwise.
    bool push_callback(lua_State* L, const char* name);
    /// The same for a name anchored in the registry: cannot raise, so usable outside a protected call.
    bool push_callback(lua_State* L, int name_ref);
    /// accept on the fast path: no protected trampoline, no std::function.
    std::optional<ScriptError> call_accept(lua_State* L, bool& accepted);
    void succeeded() { consecutive_failures_ = 0; }
    void failed(const char* callback, const ScriptError& error);
    void quarantine();
    Verdict verdict_on_failure(bool in_accept) const;

    static int api_publish(lua_State* L);
    static int api_set_trig_interval(lua_State* L);
    static int api_now(lua_State* L);
    // The event and constraint functions, in arbitration_api.cpp.
    static int api_set_event(lua_State* L);
    static int api_unset_event(lua_State* L);
    static int api_has_event(lua_State* L);
    static int api_set_constraint(lua_State* L);
    static int api_get_constraint(lua_State* L);
    /// The member, or a Lua error naming `function` on a send-side monitor.
    static arbitration::Member& member_of(lua_State* L, const char* function);
    /// Its events leave the container: the monitor is going away or was quarantined.
    void release_events();
    static Monitor& self(lua_State* L);

    std::uint64_t id_;
    MonitorSpec spec_;
    MonitorPolicy policy_;
    MonitorHost& host_;
    std::unique_ptr<LuaSandbox> sandbox_;
    int message_ref_ = LUA_NOREF;        ///< the one `msg` userdata, reused for every message
    MessageBox* message_box_ = nullptr;  ///< its memory: Lua never moves a userdata
    bool data_kept_ = false;             ///< its user value still holds the last message's data
    int api_name_ref_ = LUA_NOREF;       ///< "PortMonitor", kept alive so pushing it never allocates
    int accept_name_ref_ = LUA_NOREF;    ///< "accept", likewise
    bool has_accept_ = false;
    bool has_update_ = false;
    MonitorCounters counters_;
    std::uint32_t consecutive_failures_ = 0;
    bool quarantined_ = false;
    std::string last_error_;
};

}  // namespace plexus::daemon::monitor
