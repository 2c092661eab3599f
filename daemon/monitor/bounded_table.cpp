// The table functions that loop over a length the script controls, bounded.
//
// The stock ones loop in C over a count taken from `#t`, which a __len metamethod makes as large
// as it likes, reading and writing through __index/__newindex, which may be C functions that run
// no instruction either: table.move({}, 1, 1e15, 2) or table.insert on a table whose __len says
// 2^40 loop for days with no hook. These do the same reads and writes in the same order (table.sort
// excepted, see below) and charge a step for each.
#include <climits>

#include "bounded_functions.hpp"
#include "lua_sandbox.hpp"

namespace plexus::daemon::monitor::bounded {

namespace {

enum Access { read = 1, write = 2, length = 4 };

void step(lua_State* L) {
    LuaSandbox::charge(L, 4);
}

/// Lua's checktab: a table, or a value whose metatable has the metamethods `what` needs.
void check_table(lua_State* L, int index, int what) {
    if (lua_type(L, index) == LUA_TTABLE)
        return;
    int pushed = 1;
    auto has = [&](const char* key) {
        lua_pushstring(L, key);
        ++pushed;
        return lua_rawget(L, -pushed) != LUA_TNIL;
    };
    if (lua_getmetatable(L, index) && (!(what & read) || has("__index")) &&
        (!(what & write) || has("__newindex")) && (!(what & length) || has("__len"))) {
        lua_pop(L, pushed);
        return;
    }
    luaL_checktype(L, index, LUA_TTABLE);  // raises the usual message
}

lua_Integer checked_length(lua_State* L, int index, int what) {
    check_table(L, index, what | length);
    return luaL_len(L, index);
}

void add_field(lua_State* L, luaL_Buffer& out, lua_Integer i) {
    lua_geti(L, 1, i);
    if (!lua_isstring(L, -1))
        luaL_error(L, "invalid value (%s) at index %I in table for 'concat'", luaL_typename(L, -1),
                   static_cast<LUAI_UACINT>(i));
    luaL_addvalue(&out);
}

/// t[a] < t[b] for the values at stack indices a and b, by the comparator at index 2 or by `<`.
bool less(lua_State* L, int a, int b) {
    if (lua_isnil(L, 2))
        return lua_compare(L, a, b, LUA_OPLT) != 0;
    lua_pushvalue(L, 2);
    lua_pushvalue(L, a - 1);  // both indices are relative to the top, which just moved by one
    lua_pushvalue(L, b - 2);
    lua_call(L, 2, 1);
    const bool result = lua_toboolean(L, -1) != 0;
    lua_pop(L, 1);
    return result;
}

/// Moves t[root] down the max-heap t[root..last] (1-based, children of i at 2i and 2i+1).
void sift_down(lua_State* L, lua_Integer root, lua_Integer last) {
    lua_geti(L, 1, root);  // the value being placed, at the top until the end
    lua_Integer i = root;
    for (;;) {
        step(L);
        lua_Integer child = 2 * i;
        if (child > last)
            break;
        lua_geti(L, 1, child);
        if (child + 1 <= last) {
            lua_geti(L, 1, child + 1);
            if (less(L, -2, -1)) {
                lua_remove(L, -2);
                ++child;
            } else {
                lua_pop(L, 1);
            }
        }
        if (!less(L, -2, -1)) {  // the value is not below its larger child: it stays at i
            lua_pop(L, 1);
            break;
        }
        lua_seti(L, 1, i);  // the child moves up
        i = child;
    }
    lua_seti(L, 1, i);
}

}  // namespace

int table_insert(lua_State* L) {
    const lua_Integer first_empty = luaL_intop(+, checked_length(L, 1, read | write), 1);
    lua_Integer position = first_empty;
    switch (lua_gettop(L)) {
        case 2:
            break;
        case 3:
            position = luaL_checkinteger(L, 2);
            // position in [1, first_empty]
            luaL_argcheck(L,
                          static_cast<lua_Unsigned>(position) - 1u < static_cast<lua_Unsigned>(first_empty),
                          2, "position out of bounds");
            for (lua_Integer i = first_empty; i > position; --i) {
                step(L);
                lua_geti(L, 1, i - 1);
                lua_seti(L, 1, i);
            }
            break;
        default:
            return luaL_error(L, "wrong number of arguments to 'insert'");
    }
    lua_seti(L, 1, position);
    return 0;
}

int table_remove(lua_State* L) {
    const lua_Integer size = checked_length(L, 1, read | write);
    lua_Integer position = luaL_optinteger(L, 2, size);
    if (position != size) {
        // position in [1, size + 1]
        luaL_argcheck(L, static_cast<lua_Unsigned>(position) - 1u <= static_cast<lua_Unsigned>(size), 1,
                      "position out of bounds");  // argument 1, as Lua 5.4.4 says
    }
    lua_geti(L, 1, position);
    for (; position < size; ++position) {
        step(L);
        lua_geti(L, 1, position + 1);
        lua_seti(L, 1, position);
    }
    lua_pushnil(L);
    lua_seti(L, 1, position);
    return 1;
}

int table_move(lua_State* L) {
    const lua_Integer first = luaL_checkinteger(L, 2);
    const lua_Integer last = luaL_checkinteger(L, 3);
    const lua_Integer target = luaL_checkinteger(L, 4);
    const int destination = !lua_isnoneornil(L, 5) ? 5 : 1;
    check_table(L, 1, read);
    check_table(L, destination, write);
    if (last >= first) {
        luaL_argcheck(L, first > 0 || last < LUA_MAXINTEGER + first, 3, "too many elements to move");
        const lua_Integer count = last - first + 1;
        luaL_argcheck(L, target <= LUA_MAXINTEGER - count + 1, 4, "destination wrap around");
        // Overlapping ranges in the same table move from the end, as in Lua.
        if (target > last || target <= first ||
            (destination != 1 && !lua_compare(L, 1, destination, LUA_OPEQ))) {
            for (lua_Integer i = 0; i < count; ++i) {
                step(L);
                lua_geti(L, 1, first + i);
                lua_seti(L, destination, target + i);
            }
        } else {
            for (lua_Integer i = count - 1; i >= 0; --i) {
                step(L);
                lua_geti(L, 1, first + i);
                lua_seti(L, destination, target + i);
            }
        }
    }
    lua_pushvalue(L, destination);
    return 1;
}

int table_concat(lua_State* L) {
    lua_Integer last = checked_length(L, 1, read);
    std::size_t separator_size = 0;
    const char* separator = luaL_optlstring(L, 2, "", &separator_size);
    lua_Integer i = luaL_optinteger(L, 3, 1);
    last = luaL_optinteger(L, 4, last);
    luaL_Buffer out;
    luaL_buffinit(L, &out);
    for (; i < last; ++i) {
        step(L);
        add_field(L, out, i);
        luaL_addlstring(&out, separator, separator_size);
    }
    if (i == last)
        add_field(L, out, i);
    luaL_pushresult(&out);
    return 1;
}

int table_unpack(lua_State* L) {
    lua_Integer i = luaL_optinteger(L, 2, 1);
    const lua_Integer last = luaL_opt(L, luaL_checkinteger, 3, luaL_len(L, 1));
    if (i > last)
        return 0;
    lua_Unsigned count = static_cast<lua_Unsigned>(last) - static_cast<lua_Unsigned>(i);  // minus one
    if (count >= static_cast<unsigned int>(INT_MAX) || !lua_checkstack(L, static_cast<int>(++count)))
        return luaL_error(L, "too many results to unpack");
    for (; i < last; ++i) {  // up to last - 1, so that i never overflows
        step(L);
        lua_geti(L, 1, i);
    }
    lua_geti(L, 1, last);
    return static_cast<int>(count);
}

// A heapsort rather than Lua's quicksort: O(n log n) comparisons whatever the comparator does, no
// recursion, and a step charged per comparison round. Like Lua's, it is not stable; unlike Lua's,
// an inconsistent comparator gives some order instead of "invalid order function for sorting".
int table_sort(lua_State* L) {
    const lua_Integer size = checked_length(L, 1, read | write);
    if (size > 1) {
        luaL_argcheck(L, size < INT_MAX, 1, "array too big");
        if (!lua_isnoneornil(L, 2))
            luaL_checktype(L, 2, LUA_TFUNCTION);
        lua_settop(L, 2);
        for (lua_Integer root = size / 2; root >= 1; --root)
            sift_down(L, root, size);
        for (lua_Integer last = size; last > 1; --last) {
            // The largest, at 1, goes to the end; the value from the end sinks from the root.
            lua_geti(L, 1, 1);
            lua_geti(L, 1, last);
            lua_seti(L, 1, 1);
            lua_seti(L, 1, last);
            sift_down(L, 1, last - 1);
        }
    }
    return 0;
}

}  // namespace plexus::daemon::monitor::bounded
