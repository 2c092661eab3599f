#include "monitor.hpp"

#include <malloc.h>

#include <atomic>

#include <spdlog/spdlog.h>

#include "lua_monitor.hpp"
#include "monitor_backend.hpp"
#include "plugin_monitor.hpp"

namespace plexus::daemon::monitor {

namespace {

/// Failures logged one by one before the log only samples them.
constexpr std::uint64_t logged_failures = 10;
/// Shortest trig period: a shorter one would turn the event loop into a busy loop.
constexpr double min_trig_interval = 0.001;

std::atomic<std::uint64_t> next_monitor_id{1};

}  // namespace

Monitor::Monitor(MonitorSpec spec, const MonitorPolicy& policy, MonitorHost& host)
    : id_(next_monitor_id++), spec_(std::move(spec)), policy_(policy), host_(host) {}

std::string Monitor::description() const {
    return spec_.script.name + " (" + proto::side_name(spec_.side) + " " + spec_.source + " -> " +
           spec_.destination + ")";
}

proto::Result<std::unique_ptr<Monitor>> Monitor::create(MonitorSpec spec, const MonitorPolicy& policy,
                                                        MonitorHost& host) {
    std::unique_ptr<Monitor> monitor(new Monitor(std::move(spec), policy, host));
    auto backend = monitor->spec_.type == MonitorType::plugin ? make_plugin_monitor(*monitor)
                                                              : make_lua_monitor(*monitor, policy);
    if (!backend)
        return backend.error();  // ~Monitor takes back what create did (events, trig, ports)
    monitor->backend_ = std::move(*backend);
    monitor->has_accept_ = monitor->backend_->has_accept();
    monitor->has_update_ = monitor->backend_->has_update();
    monitor->has_reply_ = monitor->backend_->has_reply();
    spdlog::info("monitor {} created from {}", monitor->description(), monitor->spec_.script.path);
    return monitor;
}

Monitor::~Monitor() {
    if (backend_) {
        if (auto error = backend_->destroy())
            spdlog::warn("monitor {}: destroy failed: {}", description(), error->message);
        backend_.reset();
    }
    release_events();
    host_.monitor_gone(*this);
}

std::size_t Monitor::memory_in_use() const {
    return memory_in_use_.load(std::memory_order_relaxed);
}

void Monitor::note_memory() {
    memory_in_use_.store(backend_ ? backend_->memory_in_use() : 0, std::memory_order_relaxed);
}

Monitor::Verdict Monitor::verdict_on_failure(bool in_accept) const {
    switch (spec_.on_error) {
        case OnError::drop:
            return Verdict::drop;
        case OnError::pass:
            return Verdict::pass;
        case OnError::by_callback:
            break;
    }
    return in_accept ? Verdict::drop : Verdict::pass;
}

void Monitor::failed(const char* callback, const ScriptError& error) {
    ++counters_.errors;
    if (error.timeout)
        ++counters_.timeouts;
    if (error.out_of_memory)
        ++counters_.out_of_memory;
    {
        std::lock_guard lock(last_error_mutex_);
        last_error_ = std::string(callback) + ": " + error.message;
    }
    note_memory();
    if (counters_.errors <= logged_failures || counters_.errors % 1000 == 0) {
        spdlog::warn("monitor {}: {} failed ({} errors so far): {}", description(), callback,
                     counters_.errors, error.message);
    }
    if (++consecutive_failures_ >= policy_.quarantine_after)
        quarantine();
}

void Monitor::quarantine() {
    if (quarantined_)
        return;
    quarantined_ = true;
    spdlog::error("monitor {} quarantined after {} failures in a row; last: {}", description(),
                  consecutive_failures_, last_error_);
    release_events();
    host_.monitor_gone(*this);
    backend_.reset();  // closes a Lua state; a plugin's state is destroyed and the library let go
    note_memory();
    ::malloc_trim(0);  // and its memory goes back to the system now, not at the next trim
}

Monitor::Verdict Monitor::process(Message& message) {
    ++counters_.messages;
    if (!has_accept_ && !has_update_)
        return Verdict::pass;
    if (quarantined_) {
        const Verdict verdict = verdict_on_failure(has_accept_);
        counters_.dropped += verdict == Verdict::drop ? 1 : 0;
        return verdict;
    }
    const MonitorBackend::Outcome outcome = backend_->process(message);
    if (outcome.error) {
        failed(outcome.in_accept ? "accept" : "update", *outcome.error);
        const Verdict verdict = verdict_on_failure(outcome.in_accept);
        counters_.dropped += verdict == Verdict::drop ? 1 : 0;
        return verdict;
    }
    succeeded();
    if (!outcome.accepted) {
        ++counters_.dropped;
        return Verdict::drop;
    }
    if (outcome.rewritten)
        ++counters_.rewritten;
    return Verdict::pass;
}

void Monitor::reply(Message& message) {
    if (!has_reply_ || !backend_)
        return;
    ++counters_.replies;
    const MonitorBackend::Outcome outcome = backend_->reply(message);
    if (outcome.error) {
        failed("reply", *outcome.error);
        return;
    }
    succeeded();
    if (outcome.rewritten)
        ++counters_.rewritten;
}

void Monitor::trig() {
    if (!backend_)
        return;
    if (auto error = backend_->trig())
        failed("trig", *error);
    else
        succeeded();
}

proto::Result<nlohmann::json> Monitor::getparam() {
    if (!backend_)
        return proto::Error{"monitor " + description() + " is quarantined: " + last_error_};
    nlohmann::json result = nullptr;
    if (auto error = backend_->getparam(result)) {
        failed("getparam", *error);
        return proto::Error{"getparam of " + description() + " failed: " + error->message};
    }
    succeeded();
    return result;
}

proto::Result<bool> Monitor::setparam(const nlohmann::json& values) {
    if (!backend_)
        return proto::Error{"monitor " + description() + " is quarantined: " + last_error_};
    bool defined = true;
    if (auto error = backend_->setparam(values, defined)) {
        failed("setparam", *error);
        return proto::Error{"setparam of " + description() + " failed: " + error->message};
    }
    succeeded();
    return defined;
}

proto::Status Monitor::publish(const std::string& port, const nlohmann::json& value) {
    if (auto published = host_.publish(*this, port, value); !published)
        return proto::Error{"publish to '" + port + "' refused: " + published.error().message};
    return proto::Ok{};
}

proto::Status Monitor::set_trig_interval(double seconds) {
    if (!(seconds == 0 || seconds >= min_trig_interval) || seconds > 86400)
        return proto::Error{"setTrigInterval takes seconds: 0 (off) or between " +
                            std::to_string(min_trig_interval) + " and 86400"};
    host_.set_trig_interval(*this, seconds);
    return proto::Ok{};
}

double Monitor::now() const {
    return host_.now();
}

void Monitor::log(LogLevel level, std::string_view line) const {
    switch (level) {
        case LogLevel::info:
            spdlog::info("[{}] {}", description(), line);
            break;
        case LogLevel::warn:
            spdlog::warn("[{}] {}", description(), line);
            break;
        case LogLevel::error:
            spdlog::error("[{}] {}", description(), line);
            break;
    }
}

nlohmann::json Monitor::stats() const {
    return {{"script", spec_.script.name},
            {"type", spec_.type == MonitorType::plugin ? "so" : "lua"},
            {"side", proto::side_name(spec_.side)},
            {"messages", counters_.messages.load()},
            {"dropped", counters_.dropped.load()},
            {"rewritten", counters_.rewritten.load()},
            {"replies", counters_.replies.load()},
            {"errors", counters_.errors.load()},
            {"timeouts", counters_.timeouts.load()},
            {"out_of_memory", counters_.out_of_memory.load()},
            {"quarantined", quarantined()},
            {"memory_bytes", memory_in_use()},
            {"last_error", last_error()}};
}

}  // namespace plexus::daemon::monitor
