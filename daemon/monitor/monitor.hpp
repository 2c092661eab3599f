#pragma once
// Threading: one thread at a time -- created on the daemon's thread, then used only under its
// stage's monitors lock, on the stage's strand or inline on the daemon's thread (monitor/stage.hpp).
// counters(), quarantined(), last_error(), memory_in_use() and stats() may be read from the daemon's
// thread meanwhile.
//
// One port monitor on one side of one connection: a Lua script in its own sandboxed state
// (lua_monitor.*) or a compiled plugin (plugin_monitor.*), behind the same shell. It sees each
// message (accept, update), runs on a timer (trig), answers `plexus param`, and is quarantined --
// its state closed, its memory returned -- when it keeps failing. The shell keeps the counters,
// the failure policy and the PortMonitor functions both kinds call (setEvent, publish, ...).

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "../arbitration/arbiter.hpp"
#include "../core/message.hpp"
#include "lua_sandbox.hpp"
#include "monitor_policy.hpp"
#include "plexus/proto/carrier.hpp"
#include "script_library.hpp"

namespace plexus::daemon::monitor {

class Monitor;
class MonitorBackend;

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

/// What runs the monitor: `type.lua` (a script) or `type.so` (a compiled plugin).
enum class MonitorType { lua, plugin };

struct MonitorSpec {
    Script script;  ///< for a plugin: its name and the library's path; no code
    MonitorType type = MonitorType::lua;
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

/// A count written by one thread (the monitor's worker) and read by others (`plexus stats` on the
/// daemon's thread): relaxed atomic loads and stores, no locked instruction on the per-message path.
class MonitorCount {
public:
    MonitorCount() = default;
    MonitorCount(const MonitorCount& other) : value_(other.load()) {}
    MonitorCount& operator=(const MonitorCount& other) {
        value_.store(other.load(), std::memory_order_relaxed);
        return *this;
    }
    MonitorCount& operator+=(std::uint64_t n) {
        value_.store(load() + n, std::memory_order_relaxed);  // one writer: no read-modify-write
        return *this;
    }
    MonitorCount& operator++() { return *this += 1; }
    std::uint64_t load() const { return value_.load(std::memory_order_relaxed); }
    operator std::uint64_t() const { return load(); }

private:
    std::atomic<std::uint64_t> value_{0};
};

struct MonitorCounters {
    MonitorCount messages;   ///< messages the monitor saw
    MonitorCount dropped;    ///< by accept (or by a failure with the drop policy)
    MonitorCount rewritten;  ///< payloads replaced
    MonitorCount replies;    ///< answers to calls seen by reply()
    MonitorCount errors;     ///< failed calls of any callback, timeouts included
    MonitorCount timeouts;
    MonitorCount out_of_memory;
};

class Monitor {
public:
    /// Loads the script or plugin and calls create(options). Fails with the monitor's name and the
    /// error (a script's file and line), or when create refuses.
    static proto::Result<std::unique_ptr<Monitor>> create(MonitorSpec spec, const MonitorPolicy& policy,
                                                          MonitorHost& host);
    ~Monitor();
    Monitor(const Monitor&) = delete;
    Monitor& operator=(const Monitor&) = delete;

    enum class Verdict { pass, drop };
    /// Runs accept and update on a message; on pass, `message` may have been replaced.
    Verdict process(Message& message);
    /// Runs reply on the answer to a call (request/reply); `message` may be replaced. An error
    /// passes the answer on unchanged (and counts, as any callback's).
    void reply(Message& message);
    bool has_reply() const { return has_reply_; }
    void trig();
    /// getparam's table, or null when the monitor has no getparam.
    proto::Result<nlohmann::json> getparam();
    /// Calls setparam(values); false when the monitor has none.
    proto::Result<bool> setparam(const nlohmann::json& values);

    // The PortMonitor functions, called by the backends from inside a callback. Each checks its
    // arguments; errors are worded for the monitor's author ("setEvent: ...").
    proto::Status publish(const std::string& port, const nlohmann::json& value);
    proto::Status set_trig_interval(double seconds);
    double now() const;
    /// `lifetime`: seconds, none when empty (arbitration_api.cpp, like the four below).
    proto::Status set_event(const std::string& name, std::optional<double> lifetime);
    proto::Status unset_event(const std::string& name);
    proto::Result<bool> has_event(const std::string& name);
    /// Empty clears the constraint.
    proto::Status set_constraint(const std::optional<std::string>& text);
    proto::Result<std::optional<std::string>> get_constraint();
    enum class LogLevel { info, warn, error };
    /// A line in the daemon's log, tagged with the monitor's description.
    void log(LogLevel level, std::string_view line) const;

    std::uint64_t id() const { return id_; }
    const MonitorSpec& spec() const { return spec_; }
    const MonitorCounters& counters() const { return counters_; }
    bool quarantined() const { return quarantined_.load(std::memory_order_relaxed); }
    /// A copy: the monitor's worker may be writing it.
    std::string last_error() const {
        std::lock_guard lock(last_error_mutex_);
        return last_error_;
    }
    std::size_t memory_in_use() const;
    /// "certainty (recv)", for logs.
    std::string description() const;
    nlohmann::json stats() const;

private:
    Monitor(MonitorSpec spec, const MonitorPolicy& policy, MonitorHost& host);
    void succeeded() {
        consecutive_failures_ = 0;
        note_memory();
    }
    /// What memory_in_use() reports, read where the state is (the monitor's worker).
    void note_memory();
    void failed(const char* callback, const ScriptError& error);
    void quarantine();
    Verdict verdict_on_failure(bool in_accept) const;
    /// The member, or an error naming `function` on a send-side monitor.
    proto::Result<arbitration::Member*> member_for(const char* function) const;
    /// Its events leave the container: the monitor is going away or was quarantined.
    void release_events();

    std::uint64_t id_;
    MonitorSpec spec_;
    MonitorPolicy policy_;
    MonitorHost& host_;
    std::unique_ptr<MonitorBackend> backend_;  ///< null once quarantined
    bool has_accept_ = false;
    bool has_update_ = false;
    bool has_reply_ = false;
    MonitorCounters counters_;
    std::uint32_t consecutive_failures_ = 0;
    // Read by `plexus stats` on the daemon's thread while the worker writes them.
    std::atomic<bool> quarantined_{false};
    std::atomic<std::size_t> memory_in_use_{0};
    mutable std::mutex last_error_mutex_;
    std::string last_error_;
};

}  // namespace plexus::daemon::monitor
