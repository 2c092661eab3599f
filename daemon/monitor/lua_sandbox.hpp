#pragma once
// Threading: one Lua state, used by one thread at a time (its stage's strand, or the daemon's thread
// when it runs inline: monitor/stage.hpp).
//
// A Lua state that untrusted scripts can run in: only the safe libraries, a memory cap enforced by
// its allocator, and a time budget per call enforced by an instruction-count hook. Once the budget
// is spent the hook raises an error on every instruction, and the sandbox's pcall, xpcall and
// coroutine.resume re-raise it, so a script cannot catch its way past the deadline.

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include <lua.hpp>

#include "monitor_policy.hpp"
#include "plexus/proto/bytes.hpp"
#include "small_blocks.hpp"

namespace plexus::daemon::monitor {

/// How a call into the script went wrong.
struct ScriptError {
    std::string message;  ///< with the script's file, line and traceback when Lua gives them
    bool timeout = false;
    bool out_of_memory = false;
};

class LuaSandbox {
public:
    /// `print` goes to `log`. Throws std::runtime_error if the state cannot even be created.
    LuaSandbox(SandboxLimits limits, std::function<void(std::string_view)> log);
    ~LuaSandbox();
    LuaSandbox(const LuaSandbox&) = delete;
    LuaSandbox& operator=(const LuaSandbox&) = delete;

    lua_State* state() { return L_; }
    /// Keeps the value on top of the stack at the bottom of the stack for the state's life, above
    /// the ones pinned before, and gives its index: a value a call per message needs is then one
    /// lua_pushvalue away, not a registry lookup. Only outside run() and call(), with nothing but
    /// pinned values below (so at most a few: the base frame has LUA_MINSTACK slots). The index
    /// holds in the state's base frame only (call()'s callers), not inside run()'s body, which
    /// runs in a C function's frame of its own: there use the registry.
    int pin();
    std::size_t memory_in_use() const { return used_; }

    /// Compiles and runs a script's text (never bytecode) under the budget.
    proto::Status load(std::string_view code, const std::string& chunk_name);

    /// Runs `body` inside a protected call, with the time budget armed. `body` may call any Lua API
    /// function and lua_call into the script; Lua errors and C++ exceptions both end up here.
    std::optional<ScriptError> run(const std::function<void(lua_State*)>& body);

    /// The fast path for per-message calls: calls the function below `arguments` values on the
    /// stack, like lua_pcall, under the budget and with a traceback on error. Everything pushed
    /// before must have been pushed with functions that cannot raise (rawget and the like).
    std::optional<ScriptError> call(int arguments, int results);

    /// For the C functions a script can call (bounded_library.hpp): they charge their work here,
    /// in steps of a few nanoseconds each. Every `steps_per_check` steps the clock is read, and
    /// past the deadline the call is aborted exactly as the hook aborts Lua code (a timeout).
    static void charge(lua_State* L, std::int64_t steps) {
        auto& box = of(L);
        if ((box.credit_ -= steps) <= 0)
            check_budget(L);
    }
    /// Reads the clock now; raises the budget error if the budget is spent.
    static void check_budget(lua_State* L);
    static constexpr std::int64_t steps_per_check = 4096;
    /// Bytes copied or filled per step, for charges by size (allocations, memcpy).
    static constexpr std::int64_t bytes_per_step = 64;

    /// While monitors run inline on the daemon's thread (monitor/stage.hpp): the first look at the
    /// clock at or past `deadline`, in any sandbox on this thread, calls `overrun` once. The clock
    /// is looked at every few microseconds of a script's work (the hook, C functions' charges, the
    /// allocator), so `overrun` comes that soon after the deadline.
    struct InlineSlice {
        std::chrono::steady_clock::time_point deadline;
        std::function<void()> overrun;
        bool overran = false;
    };
    /// Watches `slice` on this thread until called again with null.
    static void watch_inline_slice(InlineSlice* slice);

private:
    static void* allocate(void* self, void* block, std::size_t old_size, std::size_t new_size);
    static void budget_hook(lua_State* L, lua_Debug* debug);
    static int trampoline(lua_State* L);
    static int guarded_call(lua_State* L);
    static int guarded_continue(lua_State* L, int status, lua_KContext context);
    static int text_only_load(lua_State* L);
    static int no_finalizer_setmetatable(lua_State* L);
    static int print_to_log(lua_State* L);
    static LuaSandbox& of(lua_State* L) { return **static_cast<LuaSandbox**>(lua_getextraspace(L)); }
    /// True once the deadline has passed; the first look at the clock in a call sets the deadline.
    bool budget_spent(std::chrono::steady_clock::time_point now);
    /// Every instruction of `L` raises from now on, until the call unwinds.
    void tighten_hook(lua_State* L);
    /// The allocator gave `bytes` more: they will be filled, which costs time too.
    void charge_allocation(std::size_t bytes);

    /// lua_pcall of the function below `arguments` values, with the traceback handler and the budget.
    int protected_call(int arguments, int results);
    void open_safe_libraries();
    void arm_budget();
    std::optional<ScriptError> error_from_stack(int status);

    SandboxLimits limits_;
    int pinned_ = 0;  ///< values pin() keeps above the traceback handler
    std::function<void(std::string_view)> log_;
    std::size_t used_ = 0;
    SmallBlocks blocks_;  ///< outlives the state: lua_close (in the destructor's body) gives blocks back
    std::chrono::steady_clock::time_point deadline_{};
    /// The clock is read at the first hook of a call, not at its start: a short call (fewer
    /// instructions than one hook period) never reads it.
    bool deadline_set_ = false;
    bool aborting_ = false;        ///< the budget is spent: every instruction raises until the call unwinds
    bool hook_tightened_ = false;  ///< the hook fires on every instruction since the last abort
    /// Steps C functions and the allocator may still charge before the clock is read again.
    std::int64_t credit_ = steps_per_check;
    int depth_ = 0;  ///< protected calls in progress: nested ones cannot use the handler at index 1
    lua_State* L_ = nullptr;
};

}  // namespace plexus::daemon::monitor
