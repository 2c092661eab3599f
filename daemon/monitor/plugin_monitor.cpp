#include "plugin_monitor.hpp"

#include <cstring>
#include <exception>
#include <vector>

#include <spdlog/spdlog.h>

#include "plexus/proto/cbor.hpp"
#include "plexus/proto/message.hpp"
#include "plugin_api.hpp"
#include "plugin_library.hpp"
#include "plugin_values.hpp"

namespace plexus::daemon::monitor {

namespace {

namespace values = plugin_values;

class PluginMonitor final : public MonitorBackend {
public:
    PluginMonitor(Monitor& monitor, std::shared_ptr<PluginLibrary> library)
        : monitor_(monitor), library_(std::move(library)), plugin_(library_->plugin()) {
        host_.monitor = &monitor;
    }
    ~PluginMonitor() override;

    proto::Status create();

    bool has_accept() const override { return plugin_.accept != nullptr; }
    bool has_update() const override { return plugin_.update != nullptr; }
    Outcome process(Message& message) override;
    std::optional<ScriptError> trig() override;
    std::optional<ScriptError> getparam(nlohmann::json& result) override;
    std::optional<ScriptError> setparam(const nlohmann::json& values, bool& defined) override;
    std::optional<ScriptError> destroy() override;
    std::size_t memory_in_use() const override { return 0; }  // the plugin's own heap: not known

private:
    /// Calls a callback that returns a status; an exception it throws is an error like any other.
    template <typename Call>
    std::optional<ScriptError> call(const char* callback, int& result, Call&& body);
    /// The error for a callback that returned `result` (ERROR or a value it may not return).
    ScriptError error_of(const char* callback, int result) const;

    Monitor& monitor_;
    std::shared_ptr<PluginLibrary> library_;  ///< outlives the state: destroy runs first
    const plexus_monitor_plugin& plugin_;
    plexus_host host_;
    void* state_ = nullptr;
    bool created_ = false;
    bool destroyed_ = false;
    plexus_builder update_builder_;  ///< reused for every message: its memory stays
};

template <typename Call>
std::optional<ScriptError> PluginMonitor::call(const char* callback, int& result, Call&& body) {
    host_.error.clear();
    try {
        result = body();
        return std::nullopt;
    } catch (const std::exception& e) {
        return ScriptError{std::string(callback) + " threw " + e.what()};
    } catch (...) {
        return ScriptError{std::string(callback) + " threw an exception that is not a std::exception"};
    }
}

ScriptError PluginMonitor::error_of(const char* callback, int result) const {
    if (result == PLEXUS_MONITOR_ERROR)
        return ScriptError{host_.error.empty() ? std::string(callback) + " returned PLEXUS_MONITOR_ERROR"
                                               : host_.error};
    return ScriptError{std::string(callback) + " returned " + std::to_string(result) +
                       ", not a PLEXUS_MONITOR_* code"};
}

proto::Status PluginMonitor::create() {
    const MonitorSpec& spec = monitor_.spec();
    const std::string which = "plugin '" + spec.script.name + "'";
    std::vector<plexus_option> options{{"source", spec.source.c_str()},
                                       {"destination", spec.destination.c_str()},
                                       {"side", proto::side_name(spec.side)},
                                       {"carrier", spec.carrier.c_str()}};
    for (const auto& [key, value] : spec.options)
        options.push_back({key.c_str(), value.c_str()});
    int result = PLEXUS_MONITOR_OK;
    if (plugin_.create) {
        auto error = call("create", result, [&] {
            return plugin_.create(&host_, &plugin_host_api(), options.data(), options.size(), &state_);
        });
        if (error)
            return proto::Error{which + ": create failed: " + error->message};
    }
    if (result == PLEXUS_MONITOR_REFUSE)
        return proto::Error{which + " refused the connection" +
                            (host_.error.empty() ? "" : ": " + host_.error)};
    if (result != PLEXUS_MONITOR_OK)
        return proto::Error{which + ": create failed: " + error_of("create", result).message};
    created_ = true;
    return proto::Ok{};
}

std::optional<ScriptError> PluginMonitor::destroy() {
    if (!created_ || destroyed_)
        return std::nullopt;
    destroyed_ = true;
    if (!plugin_.destroy)
        return std::nullopt;
    int ignored = 0;
    return call("destroy", ignored, [this] {
        plugin_.destroy(state_);
        return PLEXUS_MONITOR_OK;
    });
}

PluginMonitor::~PluginMonitor() {
    // Quarantine lands here without destroy(): the plugin must still free its state.
    if (auto error = destroy())
        spdlog::warn("monitor {}: destroy failed: {}", monitor_.description(), error->message);
}

MonitorBackend::Outcome PluginMonitor::process(Message& message) {
    Outcome outcome;
    auto record = proto::read_record(message.record);
    if (!record) {
        outcome.accepted = false;  // the daemon checked it on arrival; cannot happen
        return outcome;
    }
    const plexus_message view{record->source.data(), record->source.size(), record->seq,
                              static_cast<double>(record->time_ns) / 1e9,
                              plexus_value{record->payload.data(), record->payload.size()}};
    if (plugin_.accept) {
        outcome.in_accept = true;
        int result = PLEXUS_MONITOR_PASS;
        outcome.error = call("accept", result, [&] { return plugin_.accept(state_, &view); });
        if (outcome.error)
            return outcome;
        if (result != PLEXUS_MONITOR_PASS && result != PLEXUS_MONITOR_DROP) {
            outcome.error = error_of("accept", result);
            return outcome;
        }
        outcome.accepted = result == PLEXUS_MONITOR_PASS;
        if (!outcome.accepted)
            return outcome;
    }
    if (!plugin_.update)
        return outcome;
    outcome.in_accept = false;
    values::reset(&update_builder_);
    int result = PLEXUS_MONITOR_OK;
    outcome.error = call("update", result, [&] { return plugin_.update(state_, &view, &update_builder_); });
    if (!outcome.error && result != PLEXUS_MONITOR_OK)
        outcome.error = error_of("update", result);
    if (outcome.error || update_builder_.bytes.empty())
        return outcome;
    const plexus_value built = values::value_of(&update_builder_);
    if (!built.bytes) {
        outcome.error = ScriptError{"update built a replacement that is not a whole value: " +
                                    values::problem_of(update_builder_)};
        return outcome;
    }
    proto::Bytes bytes;
    proto::append_record(bytes, record->source, record->seq, record->time_ns,
                         proto::ByteView(built.bytes, built.size));
    auto chunk = std::make_shared<Chunk>(bytes.size());
    std::memcpy(chunk->data(), bytes.data(), bytes.size());
    const proto::ByteView rewritten(chunk->data(), bytes.size());
    message = Message{std::move(chunk), rewritten, record->seq};
    outcome.rewritten = true;
    return outcome;
}

std::optional<ScriptError> PluginMonitor::trig() {
    if (!plugin_.trig)
        return std::nullopt;
    int result = PLEXUS_MONITOR_OK;
    if (auto error = call("trig", result, [this] { return plugin_.trig(state_); }))
        return error;
    if (result != PLEXUS_MONITOR_OK)
        return error_of("trig", result);
    return std::nullopt;
}

std::optional<ScriptError> PluginMonitor::getparam(nlohmann::json& result) {
    if (!plugin_.getparam)
        return std::nullopt;
    plexus_builder out;
    int status = PLEXUS_MONITOR_OK;
    if (auto error = call("getparam", status, [&] { return plugin_.getparam(state_, &out); }))
        return error;
    if (status != PLEXUS_MONITOR_OK)
        return error_of("getparam", status);
    const plexus_value built = values::value_of(&out);
    if (!built.bytes || values::type(built) != PLEXUS_TYPE_MAP)
        return ScriptError{"getparam must build a map" +
                           (built.bytes ? std::string() : ": " + values::problem_of(out))};
    auto decoded = proto::decode_cbor_fast(proto::ByteView(built.bytes, built.size));
    if (!decoded)
        return ScriptError{"getparam built a value the daemon cannot read: " + decoded.error().message};
    result = std::move(*decoded);
    return std::nullopt;
}

std::optional<ScriptError> PluginMonitor::setparam(const nlohmann::json& values, bool& defined) {
    defined = plugin_.setparam != nullptr;
    if (!defined)
        return std::nullopt;
    const auto cbor = nlohmann::json::to_cbor(values);
    const plexus_value view{cbor.data(), cbor.size()};
    int status = PLEXUS_MONITOR_OK;
    if (auto error = call("setparam", status, [&] { return plugin_.setparam(state_, view); }))
        return error;
    if (status != PLEXUS_MONITOR_OK)
        return error_of("setparam", status);
    return std::nullopt;
}

}  // namespace

proto::Result<std::unique_ptr<MonitorBackend>> make_plugin_monitor(Monitor& monitor) {
    const Script& script = monitor.spec().script;
    auto library = PluginLibrary::load(script.name, script.path);
    if (!library)
        return library.error();
    auto plugin = std::make_unique<PluginMonitor>(monitor, std::move(*library));
    if (auto created = plugin->create(); !created)
        return created.error();
    return std::unique_ptr<MonitorBackend>(std::move(plugin));
}

}  // namespace plexus::daemon::monitor
