// load, bounded: compiling runs no instruction, and a 2 MB chunk of "1+1+...+1" takes ~80 ms to
// compile. The chunk reaches the compiler through a reader of ours that hands it over 4 KiB at a
// time and charges each piece, so the budget is checked every few hundred microseconds of
// compiling. A budget error raised there comes back from `load` as its error message, but the hook
// is tightened by then: the script's next instruction raises it again.
#include <algorithm>

#include "bounded_functions.hpp"
#include "lua_sandbox.hpp"

namespace plexus::daemon::monitor::bounded {

namespace {

constexpr std::size_t piece_size = 4096;
/// Compiling costs some tens of nanoseconds per byte: a step per byte.
constexpr std::int64_t steps_per_byte = 1;

// Upvalues of the reader: the chunk (a string, or the script's own reader function), the text
// being handed over, how much of it is handed over, and whether a string chunk has been taken.
constexpr int source = 1;
constexpr int text = 2;
constexpr int offset = 3;
constexpr int taken = 4;

int reader(lua_State* L) {
    std::size_t size = 0;
    const char* current = lua_tolstring(L, lua_upvalueindex(text), &size);
    auto done = static_cast<std::size_t>(lua_tointeger(L, lua_upvalueindex(offset)));
    if (!current || done >= size) {
        if (lua_type(L, lua_upvalueindex(source)) == LUA_TSTRING) {
            if (lua_toboolean(L, lua_upvalueindex(taken)))
                return 0;  // the end of the chunk
            lua_pushboolean(L, 1);
            lua_replace(L, lua_upvalueindex(taken));
            lua_pushvalue(L, lua_upvalueindex(source));
        } else {
            lua_pushvalue(L, lua_upvalueindex(source));
            lua_call(L, 0, 1);
            if (lua_isnil(L, -1))
                return 0;
            if (!lua_isstring(L, -1))
                return 1;  // load's own reader raises its error, worded and placed as always
        }
        current = lua_tolstring(L, -1, &size);
        lua_replace(L, lua_upvalueindex(text));
        done = 0;
        if (size == 0)
            return 0;  // an empty piece ends the chunk, as for Lua's own reader
    }
    const std::size_t take = std::min(piece_size, size - done);
    LuaSandbox::charge(L, static_cast<std::int64_t>(take) * steps_per_byte);
    lua_pushlstring(L, current + done, take);
    lua_pushinteger(L, static_cast<lua_Integer>(done + take));
    lua_replace(L, lua_upvalueindex(offset));
    return 1;
}

}  // namespace

void replace_chunk_with_reader(lua_State* L) {
    const bool from_string = lua_type(L, 1) == LUA_TSTRING;
    if (from_string && lua_isnoneornil(L, 2)) {
        // Lua names a string chunk after its text; a function chunk is "=(load)".
        lua_pushvalue(L, 1);
        lua_replace(L, 2);
    }
    if (!from_string && lua_type(L, 1) != LUA_TFUNCTION)
        return;  // load's own error
    lua_pushvalue(L, 1);
    lua_pushnil(L);
    lua_pushinteger(L, 0);
    lua_pushboolean(L, 0);
    lua_pushcclosure(L, reader, 4);
    lua_replace(L, 1);
}

}  // namespace plexus::daemon::monitor::bounded
