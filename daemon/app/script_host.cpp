#include "script_host.hpp"

#include <cstring>

#include <spdlog/spdlog.h>

#include "daemon.hpp"
#include "monitor/carrier_monitors.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/port_name.hpp"

namespace plexus::daemon {

namespace {

/// Monitors publishing into connections whose monitors publish again: past this, refuse.
constexpr int max_publish_depth = 4;

}  // namespace

ScriptHost::ScriptHost(asio::io_context& io, Daemon& daemon, std::shared_ptr<monitor::Workers> workers)
    : io_(io), daemon_(daemon), workers_(std::move(workers)) {}

ScriptHost::~ScriptHost() = default;

proto::Result<std::shared_ptr<monitor::MonitorChain>> ScriptHost::build_chain(
    const proto::Carrier& carrier, proto::Side side, const std::string& source,
    const std::string& destination, const std::shared_ptr<arbitration::Member>& member) {
    const monitor::ChainPlaces places{daemon_.config().script_dirs, daemon_.config().monitor_lib_dirs,
                                      daemon_.config().monitors};
    return monitor::build_carrier_chain(carrier, side, source, destination, member, places, *this);
}

std::shared_ptr<monitor::MonitorStage> ScriptHost::make_stage(std::shared_ptr<monitor::MonitorChain> chain,
                                                              std::shared_ptr<arbitration::Member> member,
                                                              monitor::MonitorStage::Options options,
                                                              std::weak_ptr<FilterClient> client) {
    options.inline_cost_limit = daemon_.config().monitors.inline_cost_limit;
    std::vector<std::uint64_t> ids;
    for (const auto& m : chain->monitors)
        ids.push_back(m->id());
    auto stage = std::make_shared<monitor::MonitorStage>(workers_, io_.get_executor(), std::move(chain),
                                                         std::move(member), options,
                                                         [this] { daemon_.notify_space(); });
    stage->attach(std::move(client));
    for (const auto id : ids)
        stages_[id] = stage;
    return stage;
}

std::size_t ScriptHost::in_flight() const {
    std::size_t total = 0;
    for (const auto& [id, weak] : stages_) {
        if (auto stage = weak.lock())
            total += stage->in_flight();
    }
    return total;
}

void ScriptHost::close_stages() {
    for (const auto& [id, weak] : stages_) {
        if (auto stage = weak.lock())
            stage->close();
    }
}

double ScriptHost::now() const {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

proto::Status ScriptHost::publish(monitor::Monitor& monitor, const std::string& name,
                                  const nlohmann::json& value) {
    // On the monitor's worker: check what can be checked here, do the rest on the daemon's thread.
    if (auto error = proto::port_name_error(name))
        return proto::Error{*error};
    const int depth = monitor::current_publish_depth();
    if (depth >= max_publish_depth)
        return proto::Error{"publish loops through monitors more than " + std::to_string(max_publish_depth) +
                            " levels deep"};
    asio::post(io_, [this, id = monitor.id(), description = monitor.description(), name, value, depth] {
        publish_now(id, description, name, value, depth + 1);
    });
    return proto::Ok{};
}

void ScriptHost::publish_now(std::uint64_t monitor_id, const std::string& description,
                             const std::string& name, const nlohmann::json& value, int depth) {
    auto& owned = ports_[monitor_id];
    std::shared_ptr<Port> port;
    for (const auto& candidate : owned) {
        if (candidate->name() == name)
            port = candidate;
    }
    if (!port) {
        auto opened = daemon_.open_hosted_port(name);
        if (!opened) {
            ++publish_dropped_;
            spdlog::warn("monitor {} cannot publish on {}: {}", description, name, opened.error().message);
            return;
        }
        port = *opened;
        owned.push_back(port);
        spdlog::info("monitor {} publishes on {}", description, name);
    }
    if (Router::blocked(*port)) {
        ++publish_dropped_;  // a script cannot wait: a full strict reader loses this one, counted
        return;
    }
    const auto cbor = nlohmann::json::to_cbor(value);
    const auto time_ns = static_cast<std::uint64_t>(now() * 1e9);
    const auto seq = ++port_seq_[name];
    proto::Bytes bytes;
    proto::append_record(bytes, name, seq, time_ns, cbor);
    auto chunk = std::make_shared<Chunk>(bytes.size());
    std::memcpy(chunk->data(), bytes.data(), bytes.size());
    const proto::ByteView record(chunk->data(), bytes.size());
    ++published_;
    Message message{std::move(chunk), record, seq};
    message.publish_depth = static_cast<std::uint8_t>(depth);
    Router::route(*port, message);
}

void ScriptHost::set_trig_interval(monitor::Monitor& monitor, double seconds) {
    // From create (the daemon's thread) or a callback (a worker): the timers live on the daemon's.
    asio::post(io_, [this, id = monitor.id(), seconds] { start_trig(id, seconds); });
}

void ScriptHost::start_trig(std::uint64_t monitor_id, double seconds) {
    trigs_.erase(monitor_id);
    if (seconds <= 0)
        return;
    auto stage = stages_.find(monitor_id);
    if (stage == stages_.end())
        return;  // its connection was refused after create, or is gone
    Trig trig;
    trig.stage = stage->second;
    trig.timer = std::make_unique<asio::steady_timer>(io_);
    trig.period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(seconds));
    trig.generation = next_generation_++;
    trig.timer->expires_after(trig.period);
    trigs_.emplace(monitor_id, std::move(trig));
    arm(monitor_id);
}

void ScriptHost::arm(std::uint64_t monitor_id) {
    auto& trig = trigs_.at(monitor_id);
    trig.timer->async_wait(
        [this, monitor_id, generation = trig.generation](const boost::system::error_code& ec) {
            if (ec)
                return;
            auto it = trigs_.find(monitor_id);
            if (it == trigs_.end() || it->second.generation != generation)
                return;
            // Fixed rate; after a stall, start again from now rather than firing a burst.
            auto& timer = *it->second.timer;
            const auto next = timer.expiry() + it->second.period;
            const auto now = std::chrono::steady_clock::now();
            timer.expires_at(next > now ? next : now + it->second.period);
            auto stage = it->second.stage.lock();
            arm(monitor_id);
            if (stage)
                stage->trig(monitor_id);  // on the monitor's worker
        });
}

void ScriptHost::monitor_gone(monitor::Monitor& monitor) {
    asio::post(io_, [this, id = monitor.id()] { forget_monitor(id); });
}

void ScriptHost::forget_monitor(std::uint64_t monitor_id) {
    trigs_.erase(monitor_id);
    stages_.erase(monitor_id);
    auto it = ports_.find(monitor_id);
    if (it == ports_.end())
        return;
    auto ports = std::move(it->second);
    ports_.erase(it);
    // Posted, not under a route() that may be walking the connections these ports rewire.
    for (const auto& port : ports) {
        port_seq_.erase(port->name());
        daemon_.close_hosted_port(port);
    }
}

}  // namespace plexus::daemon
