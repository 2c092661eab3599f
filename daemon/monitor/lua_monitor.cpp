#include "lua_monitor.hpp"

#include <cstring>
#include <string>
#include <string_view>

#include "lazy_map.hpp"
#include "lua_guard.hpp"
#include "lua_value.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::daemon::monitor {

namespace {

constexpr const char* api_table = "PortMonitor";
constexpr const char* message_type = "plexus.msg";
/// The most of a script's own words a connect refusal carries: enough for a sentence, and a
/// script cannot make the CLI's one-line error (or the reply frame) as big as it likes.
constexpr std::size_t reason_bytes = 300;

/// `text` as a connect refusal shows it: without Lua's traceback (the daemon log has it), cut at
/// reason_bytes on a UTF-8 character boundary.
std::string reason_for_user(std::string_view text) {
    if (const auto traceback = text.find("\nstack traceback:"); traceback != std::string_view::npos)
        text = text.substr(0, traceback);
    if (text.size() <= reason_bytes)
        return std::string(text);
    std::size_t end = reason_bytes;
    while (end > 0 && (static_cast<unsigned char>(text[end]) & 0xC0) == 0x80)
        --end;  // text[end] continues a character: cut before the character starts
    return std::string(text.substr(0, end)) + "...";
}

/// One message as a callback sees it; lives on the C++ stack for one process() call.
struct MessageView {
    proto::RecordView record;
    LazyMaps* lazy = nullptr;               ///< where a map payload becomes a lazy msg.data
    std::optional<nlohmann::json> decoded;  ///< the payload as first decoded: the hint for re-encoding
    bool touched = false;                   ///< msg.data exists as a Lua value (uservalue 1)
    bool assigned = false;                  ///< the script assigned msg.data
};

struct MessageBox {
    MessageView* view = nullptr;  ///< null outside a callback
};

MessageView& view_of(lua_State* L) {
    // Only the msg metatable (protected by __metatable) leads here, so argument 1 is a MessageBox.
    auto* box = static_cast<MessageBox*>(lua_touserdata(L, 1));
    if (!box || !box->view)
        luaL_error(L, "msg used after its callback returned");
    return *box->view;
}

/// Pushes msg.data: on first touch, a map as a lazily decoded table, anything else decoded.
void push_data(lua_State* L, MessageView& view) {
    if (!view.touched) {
        if (!view.lazy->push(L, view.record.payload))
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

// --- The PortMonitor functions: Lua wrappers around the Monitor shell's ---

Monitor& owner(lua_State* L) {
    return *static_cast<Monitor*>(lua_touserdata(L, lua_upvalueindex(1)));
}

/// Raises the status's error as a Lua error (the script sees it, pcall can catch it).
int raise_if_failed(lua_State* L, const proto::Status& status) {
    if (!status)
        return luaL_error(L, "%s", status.error().message.c_str());
    return 0;
}

int api_publish(lua_State* L) {
    return guard(L, [L] {
        const std::string port = luaL_checkstring(L, 1);
        luaL_checkany(L, 2);
        const auto value = to_json(L, 2);
        return raise_if_failed(L, owner(L).publish(port, value));
    });
}

int api_set_trig_interval(lua_State* L) {
    const double seconds = luaL_checknumber(L, 1);
    return guard(L, [L, seconds] { return raise_if_failed(L, owner(L).set_trig_interval(seconds)); });
}

int api_now(lua_State* L) {
    lua_pushnumber(L, owner(L).now());
    return 1;
}

int api_set_event(lua_State* L) {
    const std::string name = luaL_checkstring(L, 1);
    std::optional<double> lifetime;
    if (!lua_isnoneornil(L, 2))
        lifetime = luaL_checknumber(L, 2);
    return guard(L, [&] { return raise_if_failed(L, owner(L).set_event(name, lifetime)); });
}

int api_unset_event(lua_State* L) {
    const std::string name = luaL_checkstring(L, 1);
    return guard(L, [&] { return raise_if_failed(L, owner(L).unset_event(name)); });
}

int api_has_event(lua_State* L) {
    const std::string name = luaL_checkstring(L, 1);
    return guard(L, [&] {
        auto has = owner(L).has_event(name);
        if (!has)
            return luaL_error(L, "%s", has.error().message.c_str());
        lua_pushboolean(L, *has ? 1 : 0);
        return 1;
    });
}

int api_set_constraint(lua_State* L) {
    std::optional<std::string> text;
    if (!lua_isnoneornil(L, 1))
        text = luaL_checkstring(L, 1);
    return guard(L, [&] { return raise_if_failed(L, owner(L).set_constraint(text)); });
}

int api_get_constraint(lua_State* L) {
    return guard(L, [L] {
        auto text = owner(L).get_constraint();
        if (!text)
            return luaL_error(L, "%s", text.error().message.c_str());
        if (!*text)
            lua_pushnil(L);
        else
            lua_pushlstring(L, (*text)->data(), (*text)->size());
        return 1;
    });
}

class LuaMonitor final : public MonitorBackend {
public:
    LuaMonitor(Monitor& monitor, const MonitorPolicy& policy) : monitor_(monitor), policy_(policy) {}

    proto::Status create();

    bool has_accept() const override { return has_accept_; }
    bool has_update() const override { return has_update_; }
    Outcome process(Message& message) override;
    bool has_reply() const override { return has_reply_; }
    Outcome reply(Message& message) override;
    std::optional<ScriptError> trig() override;
    std::optional<ScriptError> getparam(nlohmann::json& result) override;
    std::optional<ScriptError> setparam(const nlohmann::json& values, bool& defined) override;
    std::optional<ScriptError> destroy() override;
    std::size_t memory_in_use() const override { return sandbox_ ? sandbox_->memory_in_use() : 0; }

private:
    void install_api(lua_State* L);
    bool has_callback(lua_State* L, const char* name);
    /// Pushes PortMonitor[name] if it is a function; false (nothing pushed) otherwise.
    bool push_callback(lua_State* L, const char* name);
    /// accept on the fast path: no protected trampoline, no std::function.
    std::optional<ScriptError> call_accept(lua_State* L, bool& accepted);
    /// Calls PortMonitor[callback](msg) if `present` (update, reply), and notes in `replacement`
    /// what the payload becomes: a value it returned other than msg, or msg.data changed in place
    /// or assigned. Runs inside the sandbox (it may raise).
    void rewrite(lua_State* L, const char* callback, bool present, MessageView& view,
                 std::optional<nlohmann::json>& replacement);
    /// Sets the msg userdata to show `view` (forgetting the previous message's data).
    void show(lua_State* L, MessageView& view);
    /// Detaches the msg userdata from `view` once the callbacks are done with it.
    void hide(const MessageView& view);

    Monitor& monitor_;
    MonitorPolicy policy_;
    LazyMaps lazy_;  ///< msg.data of a map payload; before sandbox_: its closures point here until lua_close
    std::unique_ptr<LuaSandbox> sandbox_;
    int message_ref_ = LUA_NOREF;        ///< the one `msg` userdata, reused for every message
    MessageBox* message_box_ = nullptr;  ///< its memory: Lua never moves a userdata
    bool data_kept_ = false;             ///< its user value still holds the last message's data
    int api_name_ref_ = LUA_NOREF;       ///< "PortMonitor", kept alive so pushing it never allocates
    int accept_name_ref_ = LUA_NOREF;    ///< "accept", likewise
    bool has_accept_ = false;
    /// Stack indexes of what every accept call needs (LuaSandbox::pin): the globals table, the
    /// names "PortMonitor" and "accept", the msg userdata.
    struct Pins {
        int globals = 0;
        int api_name = 0;
        int accept_name = 0;
        int message = 0;
    } pins_;
    bool has_update_ = false;
    bool has_reply_ = false;
    /// Until create has answered, the last line the script printed (at most reason_bytes and a
    /// bit): a script that refuses often says why with print, and the user should see it.
    bool remember_prints_ = true;
    std::string last_printed_;
};

void LuaMonitor::install_api(lua_State* L) {
    const std::pair<const char*, lua_CFunction> functions[] = {
        {"publish", &api_publish},
        {"setTrigInterval", &api_set_trig_interval},
        {"now", &api_now},
        {"setEvent", &api_set_event},
        {"unsetEvent", &api_unset_event},
        {"hasEvent", &api_has_event},
        {"setConstraint", &api_set_constraint},
        {"getConstraint", &api_get_constraint},
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
            lua_pushlightuserdata(L, &monitor_);
            lua_pushcclosure(L, function, 1);
            lua_setfield(L, -3, name);
        }
        lua_pop(L, 1);
    }
    lua_pop(L, 1);
}

bool LuaMonitor::push_callback(lua_State* L, const char* name) {
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

std::optional<ScriptError> LuaMonitor::call_accept(lua_State* L, bool& accepted) {
    // PortMonitor.accept looked up afresh (a script may replace or remove it at any time), from
    // values pinned at the bottom of the stack: no registry lookups, no stack shuffling. The
    // PortMonitor table stays below the call until the stack is reset.
    const int base = lua_gettop(L);
    lua_pushvalue(L, pins_.api_name);
    if (lua_rawget(L, pins_.globals) != LUA_TTABLE) {
        lua_settop(L, base);
        return std::nullopt;  // no PortMonitor table any more: everything passes
    }
    lua_pushvalue(L, pins_.accept_name);
    if (lua_rawget(L, -2) != LUA_TFUNCTION) {
        lua_settop(L, base);
        return std::nullopt;  // the script removed its accept: everything passes
    }
    lua_pushvalue(L, pins_.message);
    auto error = sandbox_->call(1, 1);
    std::optional<ScriptError> wrong_type;
    if (!error && !lua_isboolean(L, -1))
        wrong_type =
            ScriptError{std::string("accept must return true or false, not ") + luaL_typename(L, -1)};
    else if (!error)
        accepted = lua_toboolean(L, -1) != 0;
    lua_settop(L, base);
    return error ? error : wrong_type;
}

bool LuaMonitor::has_callback(lua_State* L, const char* name) {
    if (!push_callback(L, name))
        return false;
    lua_pop(L, 1);
    return true;
}

proto::Status LuaMonitor::create() {
    const MonitorSpec& spec = monitor_.spec();
    const std::string& name = spec.script.name;
    try {
        sandbox_ = std::make_unique<LuaSandbox>(policy_.limits, [this](std::string_view line) {
            monitor_.log(Monitor::LogLevel::info, line);
            if (remember_prints_)
                last_printed_ = reason_for_user(line);
        });
    } catch (const std::exception& e) {
        return proto::Error{"script '" + name + "': " + e.what()};
    }
    auto setup = sandbox_->run([this](lua_State* L) {
        lua_newtable(L);
        lua_setglobal(L, api_table);
        install_api(L);
        lazy_.install(L);
        // The msg object: a userdata with one user value (msg.data) and a metatable.
        luaL_newmetatable(L, message_type);
        lua_pushcfunction(L, message_index);
        lua_setfield(L, -2, "__index");
        lua_pushcfunction(L, message_newindex);
        lua_setfield(L, -2, "__newindex");
        lua_pushliteral(L, "msg");
        lua_setfield(L, -2, "__metatable");
        lua_pop(L, 1);
        message_box_ = new (lua_newuserdatauv(L, sizeof(MessageBox), 1)) MessageBox{};
        luaL_setmetatable(L, message_type);
        message_ref_ = luaL_ref(L, LUA_REGISTRYINDEX);
        lua_pushstring(L, api_table);
        api_name_ref_ = luaL_ref(L, LUA_REGISTRYINDEX);
        lua_pushstring(L, "accept");
        accept_name_ref_ = luaL_ref(L, LUA_REGISTRYINDEX);
    });
    if (setup)
        return proto::Error{"script '" + name + "': cannot set up its state: " + setup->message};
    lua_State* L = sandbox_->state();
    lua_rawgeti(L, LUA_REGISTRYINDEX, LUA_RIDX_GLOBALS);
    pins_.globals = sandbox_->pin();
    lua_rawgeti(L, LUA_REGISTRYINDEX, api_name_ref_);
    pins_.api_name = sandbox_->pin();
    lua_rawgeti(L, LUA_REGISTRYINDEX, accept_name_ref_);
    pins_.accept_name = sandbox_->pin();
    lua_rawgeti(L, LUA_REGISTRYINDEX, message_ref_);
    pins_.message = sandbox_->pin();
    if (auto loaded = sandbox_->load(spec.script.code, spec.script.path); !loaded)
        return proto::Error{"script '" + name + "' failed to load: " + loaded.error().message};

    bool refused = false;
    std::string returned;  // create's second result, when it refuses: `return false, "no camera"`
    auto created = sandbox_->run([this, &spec, &refused, &returned](lua_State* L) {
        install_api(L);
        if (!push_callback(L, "create"))
            return;
        lua_createtable(L, 0, static_cast<int>(spec.options.size()) + 4);
        const std::pair<const char*, std::string> fixed[] = {{"source", spec.source},
                                                             {"destination", spec.destination},
                                                             {"side", proto::side_name(spec.side)},
                                                             {"carrier", spec.carrier}};
        for (const auto& [key, value] : fixed) {
            lua_pushlstring(L, value.data(), value.size());
            lua_setfield(L, -2, key);
        }
        for (const auto& [key, value] : spec.options) {
            lua_pushlstring(L, value.data(), value.size());
            lua_setfield(L, -2, key.c_str());
        }
        lua_call(L, 1, 2);
        refused = lua_isboolean(L, -2) && !lua_toboolean(L, -2);
        // Only a string or a number: anything else would print as "table: 0x...", no reason at all.
        if (refused && (lua_type(L, -1) == LUA_TSTRING || lua_type(L, -1) == LUA_TNUMBER)) {
            std::size_t size = 0;
            const char* text = lua_tolstring(L, -1, &size);
            returned = reason_for_user(std::string_view(text, size));
        }
    });
    remember_prints_ = false;
    if (created) {
        // The whole error, traceback and all, for the script's author; the connect gets its gist.
        monitor_.log(Monitor::LogLevel::warn, "create failed: " + created->message);
        return proto::Error{"script '" + name + "': create failed: " + reason_for_user(created->message)};
    }
    if (refused) {
        // The reason it gave beside false, else the last thing it printed.
        const std::string& why = returned.empty() ? last_printed_ : returned;
        return proto::Error{"script '" + name + "' refused the connection" +
                            (why.empty() ? " (create returned false)" : ": " + why)};
    }
    auto lookup = sandbox_->run([this](lua_State* L) {
        has_accept_ = has_callback(L, "accept");
        has_update_ = has_callback(L, "update");
        has_reply_ = has_callback(L, "reply");
    });
    if (lookup)
        return proto::Error{"script '" + name + "': " + lookup->message};
    return proto::Ok{};
}

std::optional<ScriptError> LuaMonitor::destroy() {
    return sandbox_->run([this](lua_State* L) {
        if (push_callback(L, "destroy"))
            lua_call(L, 0, 0);
    });
}

MonitorBackend::Outcome LuaMonitor::process(Message& message) {
    Outcome outcome;
    auto record = proto::read_record(message.record);
    if (!record) {
        outcome.accepted = false;  // the daemon checked it on arrival; cannot happen
        return outcome;
    }
    MessageView view{*record, &lazy_, std::nullopt, false, false};
    outcome.in_accept = has_accept_;
    std::optional<nlohmann::json> replacement;
    lua_State* L = sandbox_->state();
    show(L, view);

    if (has_accept_)
        outcome.error = call_accept(L, outcome.accepted);
    if (!outcome.error && outcome.accepted && (has_update_ || view.assigned)) {
        outcome.in_accept = false;
        outcome.error =
            sandbox_->run([&](lua_State* L) { rewrite(L, "update", has_update_, view, replacement); });
    }
    hide(view);
    if (!outcome.error && outcome.accepted && replacement) {
        message = encode_message(view.record, *replacement);
        outcome.rewritten = true;
    }
    return outcome;
}

void LuaMonitor::show(lua_State* L, MessageView& view) {
    message_box_->view = &view;
    if (data_kept_) {
        lua_pushnil(L);
        lua_setiuservalue(L, pins_.message, 1);  // forget the previous message's data
        data_kept_ = false;
    }
}

void LuaMonitor::hide(const MessageView& view) {
    // The userdata outlives the call (the registry holds it): detach it from this stack frame.
    message_box_->view = nullptr;
    // Its user value is let go before the next message, unless it is a lazy table still empty.
    data_kept_ = view.assigned || (view.touched && !lazy_.pending());
    lazy_.end_message();
}

void LuaMonitor::rewrite(lua_State* L, const char* callback, bool present, MessageView& view,
                         std::optional<nlohmann::json>& replacement) {
    lua_rawgeti(L, LUA_REGISTRYINDEX, message_ref_);
    const int msg = lua_gettop(L);
    if (present && push_callback(L, callback)) {
        const int top = lua_gettop(L) - 1;
        lua_pushvalue(L, msg);
        lua_call(L, 1, LUA_MULTRET);
        const bool returned_msg = lua_gettop(L) == top || lua_rawequal(L, top + 1, msg);
        const nlohmann::json* hint = hint_of(view);
        if (!returned_msg) {
            replacement = to_json(L, top + 1, hint);
        } else if (view.touched && (view.assigned || !lazy_.pending())) {
            // msg.data may have been changed in place: compare with what was decoded.
            // (A table still lazy was neither written nor handed out in parts.)
            lua_getiuservalue(L, msg, 1);
            auto now = to_json(L, -1, hint);
            if (view.assigned || !hint || now != *hint)
                replacement = std::move(now);
        }
    } else if (view.assigned) {
        lua_getiuservalue(L, msg, 1);
        replacement = to_json(L, -1, hint_of(view));
    }
}

MonitorBackend::Outcome LuaMonitor::reply(Message& message) {
    Outcome outcome;
    auto record = proto::read_record(message.record);
    if (!record)
        return outcome;  // checked on arrival
    MessageView view{*record, &lazy_, std::nullopt, false, false};
    std::optional<nlohmann::json> replacement;
    lua_State* L = sandbox_->state();
    show(L, view);
    outcome.error = sandbox_->run([&](lua_State* L) { rewrite(L, "reply", has_reply_, view, replacement); });
    hide(view);
    if (!outcome.error && replacement) {
        message = encode_message(view.record, *replacement);
        outcome.rewritten = true;
    }
    return outcome;
}

std::optional<ScriptError> LuaMonitor::trig() {
    return sandbox_->run([this](lua_State* L) {
        if (push_callback(L, "trig"))
            lua_call(L, 0, 0);
    });
}

std::optional<ScriptError> LuaMonitor::getparam(nlohmann::json& result) {
    return sandbox_->run([this, &result](lua_State* L) {
        if (!push_callback(L, "getparam"))
            return;
        lua_call(L, 0, 1);
        if (!lua_istable(L, -1))
            luaL_error(L, "getparam must return a table, not %s", luaL_typename(L, -1));
        result = to_json(L, -1);
    });
}

std::optional<ScriptError> LuaMonitor::setparam(const nlohmann::json& values, bool& defined) {
    defined = true;
    return sandbox_->run([this, &values, &defined](lua_State* L) {
        if (!push_callback(L, "setparam")) {
            defined = false;
            return;
        }
        push_json(L, values);
        lua_call(L, 1, 0);
    });
}

}  // namespace

proto::Result<std::unique_ptr<MonitorBackend>> make_lua_monitor(Monitor& monitor,
                                                                const MonitorPolicy& policy) {
    auto lua = std::make_unique<LuaMonitor>(monitor, policy);
    if (auto created = lua->create(); !created)
        return created.error();
    return std::unique_ptr<MonitorBackend>(std::move(lua));
}

}  // namespace plexus::daemon::monitor
