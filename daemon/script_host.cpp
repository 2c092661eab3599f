#include "script_host.hpp"

#include <cstring>

#include <spdlog/spdlog.h>

#include "arbitration/carrier_rules.hpp"
#include "daemon.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/port_name.hpp"

namespace plexus::daemon {

namespace {

/// Monitors publishing into connections whose monitors publish again: past this, refuse.
constexpr int max_publish_depth = 4;

/// The clause keys a portmonitor takes for itself; the others go to the script's create(options).
proto::Result<monitor::MonitorSpec> spec_of(const proto::Clause& clause, const proto::Carrier& carrier,
                                            const std::string& source, const std::string& destination) {
    monitor::MonitorSpec spec;
    spec.side = clause.side;
    spec.source = source;
    spec.destination = destination;
    spec.carrier = carrier.text();
    std::string file;
    for (const auto& param : clause.params) {
        const std::string value = param.value.value_or("");
        if (param.key == "type") {
            if (value != "lua")
                return proto::Error{"portmonitor type '" + value + "' is not supported (only type.lua)"};
        } else if (param.key == "file") {
            file = value;
        } else if (param.key == "onerror") {
            if (value == "drop")
                spec.on_error = monitor::OnError::drop;
            else if (value == "pass")
                spec.on_error = monitor::OnError::pass;
            else
                return proto::Error{"onerror." + value + ": expected onerror.drop or onerror.pass"};
        } else if (param.key == "constraint" || param.key == "aux") {
            continue;  // the port's arbitration reads these (arbitration/carrier_rules)
        } else {
            spec.options[param.key] = value;
        }
    }
    if (file.empty())
        return proto::Error{"portmonitor clause without file.NAME"};
    spec.script.name = file;
    return spec;
}

}  // namespace

ScriptHost::ScriptHost(asio::io_context& io, Daemon& daemon) : io_(io), daemon_(daemon) {}

ScriptHost::~ScriptHost() = default;

proto::Result<std::shared_ptr<monitor::MonitorChain>> ScriptHost::build_chain(
    const proto::Carrier& carrier, proto::Side side, const std::string& source,
    const std::string& destination, const std::shared_ptr<arbitration::Member>& member) {
    auto chain = std::make_shared<monitor::MonitorChain>();
    for (const auto& clause : carrier.clauses) {
        if (clause.side != side || clause.modifier != "portmonitor" || arbitration::arbitration_only(clause))
            continue;
        auto spec = spec_of(clause, carrier, source, destination);
        if (!spec)
            return spec.error();
        auto script = monitor::find_script(spec->script.name, daemon_.config().script_dirs);
        if (!script)
            return script.error();
        spec->script = std::move(*script);
        if (side == proto::Side::recv)
            spec->member = member;
        auto created = monitor::Monitor::create(std::move(*spec), daemon_.config().monitors, *this);
        if (!created)
            return created.error();
        chain->monitors.push_back(std::move(*created));
    }
    if (chain->monitors.empty())
        return std::shared_ptr<monitor::MonitorChain>{};
    return chain;
}

double ScriptHost::now() const {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

proto::Status ScriptHost::publish(monitor::Monitor& monitor, const std::string& name,
                                  const nlohmann::json& value) {
    if (auto error = proto::port_name_error(name))
        return proto::Error{*error};
    if (publish_depth_ >= max_publish_depth)
        return proto::Error{"publish loops through monitors more than " + std::to_string(max_publish_depth) +
                            " levels deep"};
    auto& owned = ports_[monitor.id()];
    std::shared_ptr<Port> port;
    for (const auto& candidate : owned) {
        if (candidate->name() == name)
            port = candidate;
    }
    if (!port) {
        auto opened = daemon_.open_hosted_port(name);
        if (!opened)
            return opened.error();
        port = *opened;
        owned.push_back(port);
        spdlog::info("monitor {} publishes on {}", monitor.description(), name);
    }
    if (Router::blocked(*port)) {
        ++publish_dropped_;  // a script cannot wait: a full strict reader loses this one, counted
        return proto::Ok{};
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
    ++publish_depth_;
    Router::route(*port, Message{std::move(chunk), record, seq});
    --publish_depth_;
    return proto::Ok{};
}

void ScriptHost::set_trig_interval(monitor::Monitor& monitor, double seconds) {
    trigs_.erase(monitor.id());
    if (seconds <= 0)
        return;
    Trig trig;
    trig.monitor = &monitor;
    trig.timer = std::make_unique<asio::steady_timer>(io_);
    trig.period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(seconds));
    trig.generation = next_generation_++;
    trig.timer->expires_after(trig.period);
    trigs_.emplace(monitor.id(), std::move(trig));
    arm(monitor.id());
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
            monitor::Monitor* monitor = it->second.monitor;
            arm(monitor_id);
            monitor->trig();  // may change or stop its own timer, or be quarantined: all safe here
        });
}

void ScriptHost::monitor_gone(monitor::Monitor& monitor) {
    trigs_.erase(monitor.id());
    auto it = ports_.find(monitor.id());
    if (it != ports_.end()) {
        auto ports = std::move(it->second);
        ports_.erase(it);
        // Closing ports rewires connections: never under a route() that may be walking them.
        asio::post(io_, [this, ports = std::move(ports)] {
            for (const auto& port : ports) {
                port_seq_.erase(port->name());
                daemon_.close_hosted_port(port);
            }
        });
    }
}

}  // namespace plexus::daemon
