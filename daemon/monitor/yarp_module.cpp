#include "yarp_module.hpp"

#include <cstring>

namespace plexus::daemon::monitor {

namespace {

// The module, as Lua: it only reaches PortMonitor.now and print, both already in the sandbox,
// looked up when called (a script may install its PortMonitor functions after requiring).
constexpr const char* module_source = R"lua(
local print = print
local served = {
    Time_now = function() return PortMonitor.now() end,
    log = function(...) print(...) end,
}
local warned = {}
return setmetatable({}, {
    __index = function(_, name)
        if served[name] then return served[name] end
        return function()
            if not warned[name] then
                warned[name] = true
                print("warning: yarp." .. tostring(name) ..
                      " is not available in Plexus (only yarp.Time_now and yarp.log are): ignored")
            end
            return nil
        end
    end,
    __newindex = function() error("the yarp module is read-only", 2) end,
})
)lua";

// Where the loaded module is kept, so every require returns the same table.
constexpr const char* registry_key = "plexus.yarp_module";

int require(lua_State* L) {
    std::size_t size = 0;
    const char* name = luaL_checklstring(L, 1, &size);
    if (size != 4 || std::memcmp(name, "yarp", 4) != 0) {
        return luaL_error(L,
                          "require('%s'): monitor scripts have no modules; only require(\"yarp\") is "
                          "accepted, for scripts written for YARP",
                          name);
    }
    // YARP's binding also sets the global `yarp`, which its scripts use without assigning it.
    if (lua_getfield(L, LUA_REGISTRYINDEX, registry_key) == LUA_TTABLE) {
        lua_pushvalue(L, -1);
        lua_setglobal(L, "yarp");
        return 1;
    }
    lua_pop(L, 1);
    if (luaL_loadbufferx(L, module_source, std::strlen(module_source), "=yarp", "t") != LUA_OK)
        return lua_error(L);
    lua_call(L, 0, 1);
    lua_pushvalue(L, -1);
    lua_setfield(L, LUA_REGISTRYINDEX, registry_key);
    lua_pushvalue(L, -1);
    lua_setglobal(L, "yarp");
    return 1;
}

}  // namespace

void open_yarp_require(lua_State* L) {
    lua_pushcfunction(L, &require);
    lua_setglobal(L, "require");
}

}  // namespace plexus::daemon::monitor
