#pragma once
// Threading: whichever thread runs the Lua state.
//
// Puts the bounded functions in place of the stock ones in a state whose safe libraries are open,
// so that every C function a script can reach is bounded by the sandbox's time budget.
// docs/MONITORS.md lists each function and its bound.

#include <lua.hpp>

namespace plexus::daemon::monitor {

/// Replaces, in the open `string`, `table` and `utf8` libraries (and `math`'s varargs functions),
/// the functions whose stock versions can run unbounded in C. Inside a LuaSandbox only.
void open_bounded_library(lua_State* L);

}  // namespace plexus::daemon::monitor
