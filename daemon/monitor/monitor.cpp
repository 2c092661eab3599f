#include "monitor.hpp"

#include <malloc.h>

#include <cstring>

#include <spdlog/spdlog.h>

#include "lua_guard.hpp"
#include "lua_value.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::daemon::monitor {

namespace {

constexpr const char* api_table = "PortMonitor";
constexpr const char* message_type = "plexus.msg";
/// Failures logged one by one before the log only samples them.
constexpr std::uint64_t logged_failures = 10;
/// Shortest trig period: a shorter one would turn the event loop into a busy loop.
constexpr double min_trig_interval = 0.001;

std::uint64_t next_monitor_id = 1;

}  // namespace

/// One message as a callback sees it; lives on the C++ stack for one process() call.
struct MessageView {
    proto::RecordView record;
    std::optional<nlohmann::json> decoded;  ///< the payload as first decoded: the hint for re-encoding
    bool touched = false;                   ///< msg.data exists as a Lua value (uservalue 1)
    bool assigned = false;                  ///< the script assigned msg.data
};

struct MessageBox {
    MessageView* view = nullptr;  ///< null outside a callback
};

namespace {

MessageView& view_of(lua_State* L) {
    // Only the msg metatable (protected by __metatable) leads here, so argument 1 is a MessageBox.
    auto* box = static_cast<MessageBox*>(lua_touserdata(L, 1));
    if (!box || !box->view)
        luaL_error(L, "msg used after its callback returned");
    return *box->view;
}

/// Pushes msg.data, decoding the payload on first touch.
void push_data(lua_State* L, MessageView& view) {
    if (!view.touched) {
        push_cbor(L, view.record.payload);
        lua_setiuservalue(L, 1, 1);
        view.touched = true;
    }
    lua_getiuservalue(L, 1, 1);
}

/// The payload as json, decoded only when a rewrite needs it as the hint (blobs stay blobs).
const nlohmann::json* hint_of(MessageView& view) {
    if (!view.touched)
        return nullptr;
    if (!view.decoded) {
        auto decoded = proto::decode_cbor_fast(view.record.payload);
        if (!decoded)
            return nullptr;  // push_cbor took it, so this does not happen
        view.decoded = std::move(*decoded);
    }
    return &*view.decoded;
}

int message_index(lua_State* L) {
    return guard(L, [L] {
        MessageView& view = view_of(L);
        std::size_t size = 0;
        const char* key = luaL_checklstring(L, 2, &size);
        const std::string_view name(key, size);
        if (name == "data")
            push_data(L, view);
        else if (name == "source")
            lua_pushlstring(L, view.record.source.data(), view.record.source.size());
        else if (name == "seq")
            lua_pushinteger(L, static_cast<lua_Integer>(view.record.seq));
        else if (name == "time")
            lua_pushnumber(L, static_cast<double>(view.record.time_ns) / 1e9);
        else if (name == "size")
            lua_pushinteger(L, static_cast<lua_Integer>(view.record.payload.size()));
        else
            lua_pushnil(L);
        return 1;
    });
}

int message_newindex(lua_State* L) {
    MessageView& view = view_of(L);
    if (std::strcmp(luaL_checkstring(L, 2), "data") != 0)
        return luaL_error(L, "msg.%s cannot be assigned: only msg.data can", lua_tostring(L, 2));
    if (!view.touched) {
        // Keep the original as the hint, so blobs written back stay blobs.
        push_data(L, view);
        lua_pop(L, 1);
    }
    lua_settop(L, 3);
    lua_setiuservalue(L, 1, 1);
    view.assigned = true;
    return 0;
}

Message encode_message(const proto::RecordView& record, const nlohmann::json& payload) {
    const auto cbor = nlohmann::json::to_cbor(payload);
    proto::Bytes bytes;
    proto::append_record(bytes, record.source, record.seq, record.time_ns, cbor);
    auto chunk = std::make_shared<Chunk>(bytes.size());
    std::memcpy(chunk->data(), bytes.data(), bytes.size());
    const proto::ByteView view(chunk->data(), bytes.size());
    return Message{std::move(chunk), view, record.seq};
}

const char* side_name(proto::Side side) {
    return side == proto::Side::send ? "send" : "recv";
}

}  // namespace

Monitor::Monitor(MonitorSpec spec, const MonitorPolicy& policy, MonitorHost& host)
    : id_(next_monitor_id++), spec_(std::move(spec)), policy_(policy), host_(host) {}

std::string Monitor::description() const {
    return spec_.script.name + " (" + side_name(spec_.side) + " " + spec_.source + " -> " +
           spec_.destination + ")";
}

Monitor& Monitor::self(lua_State* L) {
    return *static_cast<Monitor*>(lua_touserdata(L, lua_upvalueindex(1)));
}

int Monitor::api_publish(lua_State* L) {
    return guard(L, [L] {
        const std::string port = luaL_checkstring(L, 1);
        luaL_checkany(L, 2);
        const auto value = to_json(L, 2);
        Monitor& monitor = self(L);
        if (auto published = monitor.host_.publish(monitor, port, value); !published)
            return luaL_error(L, "publish to '%s' refused: %s", port.c_str(),
                              published.error().message.c_str());
        return 0;
    });
}

int Monitor::api_set_trig_interval(lua_State* L) {
    const double seconds = luaL_checknumber(L, 1);
    if (!(seconds == 0 || seconds >= min_trig_interval) || seconds > 86400)
        return luaL_error(L, "setTrigInterval takes seconds: 0 (off) or between %f and 86400",
                          min_trig_interval);
    Monitor& monitor = self(L);
    monitor.host_.set_trig_interval(monitor, seconds);
    return 0;
}

int Monitor::api_now(lua_State* L) {
    lua_pushnumber(L, self(L).host_.now());
    return 1;
}

void Monitor::install_api(lua_State* L) {
    const std::pair<const char*, lua_CFunction> functions[] = {
        {"publish", &Monitor::api_publish},
        {"setTrigInterval", &Monitor::api_set_trig_interval},
        {"now", &Monitor::api_now},
        {"setEvent", &Monitor::api_set_event},
        {"unsetEvent", &Monitor::api_unset_event},
        {"hasEvent", &Monitor::api_has_event},
        {"setConstraint", &Monitor::api_set_constraint},
        {"getConstraint", &Monitor::api_get_constraint},
    };
    // Into the current PortMonitor table: a script that replaced it with its own keeps the API.
    if (lua_getglobal(L, api_table) != LUA_TTABLE) {
        lua_pop(L, 1);
        lua_newtable(L);
        lua_pushvalue(L, -1);
        lua_setglobal(L, api_table);
    }
    for (const auto& [name, function] : functions) {
        if (lua_getfield(L, -1, name) == LUA_TNIL) {
            lua_pushlightuserdata(L, this);
            lua_pushcclosure(L, function, 1);
            lua_setfield(L, -3, name);
        }
        lua_pop(L, 1);
    }
    lua_pop(L, 1);
}

bool Monitor::push_callback(lua_State* L, const char* name) {
    // Raw look-ups: a script's metatables must not run here.
    lua_rawgeti(L, LUA_REGISTRYINDEX, LUA_RIDX_GLOBALS);
    lua_pushstring(L, api_table);
    if (lua_rawget(L, -2) != LUA_TTABLE) {
        lua_pop(L, 2);
        return false;
    }
    lua_pushstring(L, name);
    if (lua_rawget(L, -2) != LUA_TFUNCTION) {
        lua_pop(L, 3);
        return false;
    }
    lua_replace(L, -3);
    lua_pop(L, 1);
    return true;
}

bool Monitor::push_callback(lua_State* L, int name_ref) {
    if (!lua_checkstack(L, 4))
        return false;
    lua_rawgeti(L, LUA_REGISTRYINDEX, LUA_RIDX_GLOBALS);
    lua_rawgeti(L, LUA_REGISTRYINDEX, api_name_ref_);
    if (lua_rawget(L, -2) != LUA_TTABLE) {
        lua_pop(L, 2);
        return false;
    }
    lua_rawgeti(L, LUA_REGISTRYINDEX, name_ref);
    if (lua_rawget(L, -2) != LUA_TFUNCTION) {
        lua_pop(L, 3);
        return false;
    }
    lua_replace(L, -3);
    lua_pop(L, 1);
    return true;
}

std::optional<ScriptError> Monitor::call_accept(lua_State* L, bool& accepted) {
    const int base = lua_gettop(L);
    if (!push_callback(L, accept_name_ref_))
        return std::nullopt;  // the script removed its accept: everything passes
    lua_rawgeti(L, LUA_REGISTRYINDEX, message_ref_);
    auto error = sandbox_->call(1, 1);
    if (error)
        return error;
    std::optional<ScriptError> wrong_type;
    if (!lua_isboolean(L, -1))
        wrong_type =
            ScriptError{std::string("accept must return true or false, not ") + luaL_typename(L, -1)};
    accepted = lua_toboolean(L, -1) != 0;
    lua_settop(L, base);
    return wrong_type;
}

bool Monitor::has_callback(lua_State* L, const char* name) {
    if (!push_callback(L, name))
        return false;
    lua_pop(L, 1);
    return true;
}

proto::Result<std::unique_ptr<Monitor>> Monitor::create(MonitorSpec spec, const MonitorPolicy& policy,
                                                        MonitorHost& host) {
    std::unique_ptr<Monitor> monitor(new Monitor(std::move(spec), policy, host));
    Monitor& m = *monitor;
    const std::string& name = m.spec_.script.name;
    try {
        m.sandbox_ = std::make_unique<LuaSandbox>(
            policy.limits, [&m](std::string_view line) { spdlog::info("[{}] {}", m.description(), line); });
    } catch (const std::exception& e) {
        return proto::Error{"script '" + name + "': " + e.what()};
    }
    auto setup = m.sandbox_->run([&m](lua_State* L) {
        lua_newtable(L);
        lua_setglobal(L, api_table);
        m.install_api(L);
        // The msg object: a userdata with one user value (msg.data) and a metatable.
        luaL_newmetatable(L, message_type);
        lua_pushcfunction(L, message_index);
        lua_setfield(L, -2, "__index");
        lua_pushcfunction(L, message_newindex);
        lua_setfield(L, -2, "__newindex");
        lua_pushliteral(L, "msg");
        lua_setfield(L, -2, "__metatable");
        lua_pop(L, 1);
        m.message_box_ = new (lua_newuserdatauv(L, sizeof(MessageBox), 1)) MessageBox{};
        luaL_setmetatable(L, message_type);
        m.message_ref_ = luaL_ref(L, LUA_REGISTRYINDEX);
        lua_pushstring(L, api_table);
        m.api_name_ref_ = luaL_ref(L, LUA_REGISTRYINDEX);
        lua_pushstring(L, "accept");
        m.accept_name_ref_ = luaL_ref(L, LUA_REGISTRYINDEX);
    });
    if (setup)
        return proto::Error{"script '" + name + "': cannot set up its state: " + setup->message};
    if (auto loaded = m.sandbox_->load(m.spec_.script.code, m.spec_.script.path); !loaded)
        return proto::Error{"script '" + name + "' failed to load: " + loaded.error().message};

    bool refused = false;
    auto created = m.sandbox_->run([&m, &refused](lua_State* L) {
        m.install_api(L);
        if (!m.push_callback(L, "create"))
            return;
        lua_createtable(L, 0, static_cast<int>(m.spec_.options.size()) + 4);
        const std::pair<const char*, std::string> fixed[] = {{"source", m.spec_.source},
                                                             {"destination", m.spec_.destination},
                                                             {"side", side_name(m.spec_.side)},
                                                             {"carrier", m.spec_.carrier}};
        for (const auto& [key, value] : fixed) {
            lua_pushlstring(L, value.data(), value.size());
            lua_setfield(L, -2, key);
        }
        for (const auto& [key, value] : m.spec_.options) {
            lua_pushlstring(L, value.data(), value.size());
            lua_setfield(L, -2, key.c_str());
        }
        lua_call(L, 1, 1);
        refused = lua_isboolean(L, -1) && !lua_toboolean(L, -1);
    });
    if (created)
        return proto::Error{"script '" + name + "': create failed: " + created->message};
    if (refused)
        return proto::Error{"script '" + name + "' refused the connection (create returned false)"};
    auto lookup = m.sandbox_->run([&m](lua_State* L) {
        m.has_accept_ = m.has_callback(L, "accept");
        m.has_update_ = m.has_callback(L, "update");
    });
    if (lookup)
        return proto::Error{"script '" + name + "': " + lookup->message};
    spdlog::info("monitor {} created from {}", m.description(), m.spec_.script.path);
    return monitor;
}

Monitor::~Monitor() {
    if (sandbox_) {
        auto error = sandbox_->run([this](lua_State* L) {
            if (push_callback(L, "destroy"))
                lua_call(L, 0, 0);
        });
        if (error)
            spdlog::warn("monitor {}: destroy failed: {}", description(), error->message);
    }
    release_events();
    host_.monitor_gone(*this);
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
    last_error_ = std::string(callback) + ": " + error.message;
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
    sandbox_.reset();  // closes the state
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
    auto record = proto::decode_record(message.record);
    if (!record)
        return Verdict::drop;  // the daemon checked it on arrival; cannot happen
    MessageView view{*record, std::nullopt, false, false};
    bool accepted = true;
    bool in_accept = has_accept_;
    std::optional<nlohmann::json> replacement;
    lua_State* L = sandbox_->state();
    message_box_->view = &view;
    if (data_kept_) {
        lua_rawgeti(L, LUA_REGISTRYINDEX, message_ref_);
        lua_pushnil(L);
        lua_setiuservalue(L, -2, 1);  // forget the previous message's data
        lua_pop(L, 1);
        data_kept_ = false;
    }

    std::optional<ScriptError> error;
    if (has_accept_)
        error = call_accept(L, accepted);
    if (!error && accepted && (has_update_ || view.assigned)) {
        in_accept = false;
        error = sandbox_->run([&](lua_State* L) {
            lua_rawgeti(L, LUA_REGISTRYINDEX, message_ref_);
            const int msg = lua_gettop(L);
            if (has_update_ && push_callback(L, "update")) {
                const int top = lua_gettop(L) - 1;
                lua_pushvalue(L, msg);
                lua_call(L, 1, LUA_MULTRET);
                const bool returned_msg = lua_gettop(L) == top || lua_rawequal(L, top + 1, msg);
                const nlohmann::json* hint = hint_of(view);
                if (!returned_msg) {
                    replacement = to_json(L, top + 1, hint);
                } else if (view.touched) {
                    // msg.data may have been changed in place: compare with what was decoded.
                    lua_getiuservalue(L, msg, 1);
                    auto now = to_json(L, -1, hint);
                    if (view.assigned || !hint || now != *hint)
                        replacement = std::move(now);
                }
            } else if (view.assigned) {
                lua_getiuservalue(L, msg, 1);
                replacement = to_json(L, -1, hint_of(view));
            }
        });
    }
    // The userdata outlives the call (the registry holds it): detach it from this stack frame.
    message_box_->view = nullptr;
    data_kept_ = view.touched || view.assigned;
    if (error) {
        failed(in_accept ? "accept" : "update", *error);
        const Verdict verdict = verdict_on_failure(in_accept);
        counters_.dropped += verdict == Verdict::drop ? 1 : 0;
        return verdict;
    }
    succeeded();
    if (!accepted) {
        ++counters_.dropped;
        return Verdict::drop;
    }
    if (replacement) {
        message = encode_message(view.record, *replacement);
        ++counters_.rewritten;
    }
    return Verdict::pass;
}

void Monitor::trig() {
    if (!sandbox_)
        return;
    auto error = sandbox_->run([this](lua_State* L) {
        if (push_callback(L, "trig"))
            lua_call(L, 0, 0);
    });
    if (error)
        failed("trig", *error);
    else
        succeeded();
}

proto::Result<nlohmann::json> Monitor::getparam() {
    if (!sandbox_)
        return proto::Error{"monitor " + description() + " is quarantined: " + last_error_};
    nlohmann::json result = nullptr;
    auto error = sandbox_->run([this, &result](lua_State* L) {
        if (!push_callback(L, "getparam"))
            return;
        lua_call(L, 0, 1);
        if (!lua_istable(L, -1))
            luaL_error(L, "getparam must return a table, not %s", luaL_typename(L, -1));
        result = to_json(L, -1);
    });
    if (error) {
        failed("getparam", *error);
        return proto::Error{"getparam of " + description() + " failed: " + error->message};
    }
    succeeded();
    return result;
}

proto::Result<bool> Monitor::setparam(const nlohmann::json& values) {
    if (!sandbox_)
        return proto::Error{"monitor " + description() + " is quarantined: " + last_error_};
    bool defined = true;
    auto error = sandbox_->run([this, &values, &defined](lua_State* L) {
        if (!push_callback(L, "setparam")) {
            defined = false;
            return;
        }
        push_json(L, values);
        lua_call(L, 1, 0);
    });
    if (error) {
        failed("setparam", *error);
        return proto::Error{"setparam of " + description() + " failed: " + error->message};
    }
    succeeded();
    return defined;
}

nlohmann::json Monitor::stats() const {
    return {{"script", spec_.script.name},      {"side", side_name(spec_.side)},
            {"messages", counters_.messages},   {"dropped", counters_.dropped},
            {"rewritten", counters_.rewritten}, {"errors", counters_.errors},
            {"timeouts", counters_.timeouts},   {"out_of_memory", counters_.out_of_memory},
            {"quarantined", quarantined_},      {"memory_bytes", memory_in_use()},
            {"last_error", last_error_}};
}

}  // namespace plexus::daemon::monitor
