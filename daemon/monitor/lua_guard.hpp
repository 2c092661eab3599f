#pragma once

#include <exception>
#include <string>

#include <lua.hpp>

namespace plexus::daemon::monitor {

/// Turns a C++ exception inside a Lua-called function into a Lua error. Lua errors are C++
/// exceptions of another type in this build of Lua and pass through untouched.
template <typename F>
int guard(lua_State* L, F&& body) {
    std::string failure;
    try {
        return body();
    } catch (const std::exception& e) {
        failure = e.what();
    }
    lua_pushlstring(L, failure.data(), failure.size());
    return lua_error(L);
}

}  // namespace plexus::daemon::monitor
