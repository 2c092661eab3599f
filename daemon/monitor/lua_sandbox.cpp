#include "lua_sandbox.hpp"

#include "bounded_functions.hpp"
#include "bounded_library.hpp"
#include "yarp_module.hpp"

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <new>
#include <stdexcept>

namespace plexus::daemon::monitor {

namespace {

/// Instructions between two looks at the clock: small enough to stop a loop within microseconds
/// of the deadline, large enough that the look costs nothing measurable.
constexpr int instructions_per_check = 1000;

/// Where the traceback message handler lives on the state's stack, from its creation on.
constexpr int traceback_index = 1;

int traceback(lua_State* L) {
    const char* message = lua_tostring(L, 1);
    if (!message)
        message = lua_pushfstring(L, "(error object is a %s value)", luaL_typename(L, 1));
    luaL_traceback(L, L, message, 1);
    return 1;
}

}  // namespace

LuaSandbox::LuaSandbox(SandboxLimits limits, std::function<void(std::string_view)> log)
    : limits_(limits), log_(std::move(log)) {
    L_ = lua_newstate(&LuaSandbox::allocate, this);
    if (!L_)
        throw std::runtime_error("cannot create a Lua state within the memory cap");
    *static_cast<LuaSandbox**>(lua_getextraspace(L_)) = this;
    // An error outside any protected call would abort the daemon; make it an exception instead
    // (this build of Lua is C++, so unwinding through it is safe).
    lua_atpanic(L_, [](lua_State* L) -> int {
        const char* message = lua_tostring(L, -1);
        throw std::runtime_error(std::string("Lua error outside a protected call: ") +
                                 (message ? message : "?"));
    });
    lua_sethook(L_, &LuaSandbox::budget_hook, LUA_MASKCOUNT, instructions_per_check);
    // Each message leaves a little garbage (its decoded payload) that dies young: the generational
    // collector handles exactly that pattern more cheaply than the incremental one.
    lua_gc(L_, LUA_GCGEN, 0, 0);
    // The message handler of every protected call stays at the bottom of the stack, so that a
    // call per message does not push and remove it.
    lua_pushcfunction(L_, traceback);
    if (auto error = run([this](lua_State*) { open_safe_libraries(); })) {
        lua_close(L_);
        L_ = nullptr;
        throw std::runtime_error("cannot set up the script sandbox: " + error->message);
    }
}

int LuaSandbox::pin() {
    const int index = lua_gettop(L_);
    // The traceback handler, the ones pinned before, this one; and room left in the base frame's
    // LUA_MINSTACK slots for what a call pushes above them.
    if (index != pinned_ + 2 || index > 8)
        throw std::logic_error("LuaSandbox::pin: the stack holds more than a few pinned values");
    ++pinned_;
    return index;
}

LuaSandbox::~LuaSandbox() {
    if (L_) {
        arm_budget();  // finalizers that lua_close runs get the same budget as any call
        lua_close(L_);
    }
}

void* LuaSandbox::allocate(void* self, void* block, std::size_t old_size, std::size_t new_size) {
    auto& box = *static_cast<LuaSandbox*>(self);
    const std::size_t old_bytes = block ? old_size : 0;
    if (new_size == 0) {
        if (block)
            box.blocks_.give(block, old_bytes);
        box.used_ -= old_bytes;
        return nullptr;
    }
    // Growing past the cap fails, which Lua turns into a "not enough memory" error after a full
    // collection; shrinking must never fail.
    if (new_size > old_bytes && box.used_ - old_bytes + new_size > box.limits_.memory_bytes)
        return nullptr;
    void* moved = nullptr;
    if (block && SmallBlocks::same_class(old_bytes, new_size)) {
        moved = block;
    } else if (block && old_bytes > SmallBlocks::largest && new_size > SmallBlocks::largest) {
        moved = std::realloc(block, new_size);
    } else {
        moved = box.blocks_.take(new_size);
        if (moved && block) {
            std::memcpy(moved, block, std::min(old_bytes, new_size));
            box.blocks_.give(block, old_bytes);
        }
    }
    if (!moved && block && new_size <= old_bytes)
        moved = block;  // a shrink must not fail: keep the larger block (it serves the smaller class too)
    if (!moved)
        return nullptr;
    box.used_ = box.used_ - old_bytes + new_size;
    if (new_size > old_bytes && box.depth_ > 0)
        box.charge_allocation(new_size - old_bytes);
    return moved;
}

void LuaSandbox::arm_budget() {
    deadline_set_ = false;
    aborting_ = false;
    if (hook_tightened_) {
        lua_sethook(L_, &LuaSandbox::budget_hook, LUA_MASKCOUNT, instructions_per_check);
        hook_tightened_ = false;
    }
}

namespace {
thread_local LuaSandbox::InlineSlice* t_inline_slice = nullptr;
}  // namespace

void LuaSandbox::watch_inline_slice(InlineSlice* slice) {
    t_inline_slice = slice;
}

bool LuaSandbox::budget_spent(std::chrono::steady_clock::time_point now) {
    if (auto* slice = t_inline_slice; slice && !slice->overran && now >= slice->deadline) {
        slice->overran = true;  // before the call: it hands the event loop over, once
        slice->overrun();
    }
    if (aborting_)
        return true;
    if (!deadline_set_) {
        deadline_ = now + limits_.budget;
        deadline_set_ = true;
        return false;
    }
    return now >= deadline_;
}

void LuaSandbox::tighten_hook(lua_State* L) {
    aborting_ = true;
    hook_tightened_ = true;
    // From now on every instruction raises, so a pcall in the script cannot resume the loop.
    lua_sethook(L, &LuaSandbox::budget_hook, LUA_MASKCOUNT, 1);
}

void LuaSandbox::budget_hook(lua_State* L, lua_Debug*) {
    auto& box = of(L);
    if (!box.budget_spent(std::chrono::steady_clock::now()))
        return;
    box.tighten_hook(L);
    luaL_error(L, "time budget of %d ms exceeded", static_cast<int>(box.limits_.budget.count()));
}

void LuaSandbox::check_budget(lua_State* L) {
    auto& box = of(L);
    box.credit_ = steps_per_check;
    if (!box.budget_spent(std::chrono::steady_clock::now()))
        return;
    box.tighten_hook(L);
    luaL_error(L, "time budget of %d ms exceeded", static_cast<int>(box.limits_.budget.count()));
}

void LuaSandbox::charge_allocation(std::size_t bytes) {
    // Whatever allocates n bytes does O(n) work filling them, often in C code that runs no
    // instruction (string.rep, upper, concatenation...): charging it here bounds a loop of such
    // calls to one hook period. The allocator cannot raise (Lua does not expect it to), so past the
    // deadline it only tightens the hook: the next instruction raises.
    credit_ -= static_cast<std::int64_t>(bytes) / bytes_per_step;
    if (credit_ > 0)
        return;
    credit_ = steps_per_check;
    if (!aborting_ && budget_spent(std::chrono::steady_clock::now()))
        tighten_hook(L_);
}

int LuaSandbox::guarded_call(lua_State* L) {
    const int arguments = lua_gettop(L);
    lua_pushvalue(L, lua_upvalueindex(1));
    lua_insert(L, 1);
    lua_callk(L, arguments, LUA_MULTRET, 0, &LuaSandbox::guarded_continue);
    return guarded_continue(L, LUA_OK, 0);
}

int LuaSandbox::guarded_continue(lua_State* L, int, lua_KContext) {
    auto& box = of(L);
    if (box.aborting_)
        return luaL_error(L, "time budget of %d ms exceeded", static_cast<int>(box.limits_.budget.count()));
    return lua_gettop(L);
}

int LuaSandbox::text_only_load(lua_State* L) {
    // load(chunk [, chunkname [, mode [, env]]]), with mode forced to "t": no bytecode, ever.
    if (lua_gettop(L) < 3)
        lua_settop(L, 3);
    bounded::replace_chunk_with_reader(L);  // compiling is charged to the budget
    lua_pushliteral(L, "t");
    lua_replace(L, 3);
    lua_pushvalue(L, lua_upvalueindex(1));
    lua_insert(L, 1);
    lua_call(L, lua_gettop(L) - 1, LUA_MULTRET);
    return lua_gettop(L);
}

int LuaSandbox::no_finalizer_setmetatable(lua_State* L) {
    // Lua 5.4 runs __gc metamethods with the debug hooks off: a finalizer would run outside the
    // budget, for ever if it loops. An object is marked for finalization only if its metatable has
    // __gc when it is set, so refusing such a metatable here closes that door for good.
    if (lua_type(L, 2) == LUA_TTABLE) {
        lua_pushliteral(L, "__gc");
        const bool finalizer = lua_rawget(L, 2) != LUA_TNIL;
        lua_pop(L, 1);
        if (finalizer)
            return luaL_error(L,
                              "setmetatable: a metatable with __gc is refused in monitors (finalizers "
                              "would run outside the time budget)");
    }
    lua_pushvalue(L, lua_upvalueindex(1));
    lua_insert(L, 1);
    lua_call(L, lua_gettop(L) - 1, LUA_MULTRET);
    return lua_gettop(L);
}

int LuaSandbox::print_to_log(lua_State* L) {
    // Counted before luaL_buffinit: in Lua 5.4 it pushes a slot of its own (the buffer's
    // placeholder), which counted after would print as one more argument, "userdata: 0x...".
    const int n = lua_gettop(L);
    luaL_Buffer line;
    luaL_buffinit(L, &line);
    charge(L, n);  // the line's bytes are charged as they are allocated
    for (int i = 1; i <= n; ++i) {
        if (i > 1)
            luaL_addchar(&line, '\t');
        luaL_tolstring(L, i, nullptr);
        luaL_addvalue(&line);
    }
    luaL_pushresult(&line);
    std::size_t size = 0;
    const char* text = lua_tolstring(L, -1, &size);
    if (of(L).log_)
        of(L).log_(std::string_view(text, size));
    return 0;
}

void LuaSandbox::open_safe_libraries() {
    lua_State* L = L_;
    const std::pair<const char*, lua_CFunction> libraries[] = {
        {LUA_GNAME, luaopen_base},       {LUA_STRLIBNAME, luaopen_string}, {LUA_TABLIBNAME, luaopen_table},
        {LUA_MATHLIBNAME, luaopen_math}, {LUA_UTF8LIBNAME, luaopen_utf8},  {LUA_COLIBNAME, luaopen_coroutine},
    };
    for (const auto& [name, open] : libraries) {
        luaL_requiref(L, name, open, 1);
        lua_pop(L, 1);
    }
    for (const char* unsafe : {"dofile", "loadfile", "collectgarbage"}) {
        lua_pushnil(L);
        lua_setglobal(L, unsafe);
    }
    lua_getglobal(L, LUA_STRLIBNAME);
    lua_pushnil(L);
    lua_setfield(L, -2, "dump");
    lua_pop(L, 1);
    // The C functions that could run unbounded give way to bounded ones (docs/MONITORS.md).
    open_bounded_library(L);

    for (const char* catcher : {"pcall", "xpcall"}) {
        lua_getglobal(L, catcher);
        lua_pushcclosure(L, &LuaSandbox::guarded_call, 1);
        lua_setglobal(L, catcher);
    }
    lua_getglobal(L, LUA_COLIBNAME);
    lua_getfield(L, -1, "resume");
    lua_pushcclosure(L, &LuaSandbox::guarded_call, 1);
    lua_setfield(L, -2, "resume");
    lua_pop(L, 1);

    lua_getglobal(L, "load");
    lua_pushcclosure(L, &LuaSandbox::text_only_load, 1);
    lua_setglobal(L, "load");
    lua_getglobal(L, "setmetatable");
    lua_pushcclosure(L, &LuaSandbox::no_finalizer_setmetatable, 1);
    lua_setglobal(L, "setmetatable");
    lua_pushcfunction(L, &LuaSandbox::print_to_log);
    lua_setglobal(L, "print");
    // `require` answers "yarp" only: the first line of scripts written for YARP.
    open_yarp_require(L);
}

int LuaSandbox::trampoline(lua_State* L) {
    const auto& body = *static_cast<const std::function<void(lua_State*)>*>(lua_touserdata(L, 1));
    lua_settop(L, 0);
    std::string failure;
    try {
        body(L);
        return 0;
    } catch (const std::bad_alloc&) {
        failure = "not enough memory";
    } catch (const std::exception& e) {
        failure = e.what();
    }
    // Outside the catch block: a Lua error is itself a C++ exception in this build of Lua.
    lua_pushlstring(L, failure.data(), failure.size());
    return lua_error(L);
}

std::optional<ScriptError> LuaSandbox::run(const std::function<void(lua_State*)>& body) {
    if (!L_)
        return ScriptError{"the script's Lua state is closed", false, false};
    const int base = lua_gettop(L_);
    lua_pushcfunction(L_, &LuaSandbox::trampoline);
    lua_pushlightuserdata(L_, const_cast<void*>(static_cast<const void*>(&body)));
    const int status = protected_call(1, 0);
    auto error = error_from_stack(status);
    lua_settop(L_, base);
    return error;
}

std::optional<ScriptError> LuaSandbox::error_from_stack(int status) {
    std::optional<ScriptError> error;
    if (status != LUA_OK) {
        std::size_t size = 0;
        const char* text = lua_tolstring(L_, -1, &size);
        error = ScriptError{text ? std::string(text, size) : std::string("(error without a message)"),
                            aborting_, status == LUA_ERRMEM};
    }
    aborting_ = false;
    return error;
}

int LuaSandbox::protected_call(int arguments, int results) {
    arm_budget();
    if (depth_ == 0) {
        ++depth_;
        const int status = lua_pcall(L_, arguments, results, traceback_index);
        --depth_;
        return status;
    }
    // Inside another call (from a C function the script called), index 1 is that function's first
    // argument: the handler goes below the function instead, and is taken away after.
    const int function = lua_gettop(L_) - arguments;
    lua_pushcfunction(L_, traceback);
    lua_insert(L_, function);
    ++depth_;
    const int status = lua_pcall(L_, arguments, results, function);
    --depth_;
    lua_remove(L_, function);
    return status;
}

std::optional<ScriptError> LuaSandbox::call(int arguments, int results) {
    const int function = lua_gettop(L_) - arguments;
    const int status = protected_call(arguments, results);
    auto error = error_from_stack(status);
    if (error)
        lua_settop(L_, function - 1);
    return error;
}

proto::Status LuaSandbox::load(std::string_view code, const std::string& chunk_name) {
    auto error = run([&](lua_State* L) {
        const std::string name = "@" + chunk_name;
        if (luaL_loadbufferx(L, code.data(), code.size(), name.c_str(), "t") != LUA_OK)
            lua_error(L);
        lua_call(L, 0, 0);
    });
    if (error)
        return proto::Error{error->message};
    return proto::Ok{};
}

}  // namespace plexus::daemon::monitor
