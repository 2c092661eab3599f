#include "lazy_map.hpp"

#include <bit>
#include <cmath>
#include <cstring>
#include <string_view>

#include "cbor_reader.hpp"
#include "lua_value.hpp"

namespace plexus::daemon::monitor {

namespace {

/// Reads of one lazy table before it is materialized: each read scans the map, so a script that
/// reads many fields is better served by the plain table.
constexpr int max_lazy_reads = 8;

/// The metatable's key of the materializing function: a light userdata, so no script can name it.
const char materialize_key = 0;

enum class KeyKind { text, integer, other };

struct LuaKey {
    KeyKind kind = KeyKind::other;
    std::string_view text;
    lua_Integer integer = 0;
};

/// The key at `index` as a field of a decoded map could have it (a float with an integral value is
/// the same key as the integer, as in any Lua table).
LuaKey key_at(lua_State* L, int index) {
    LuaKey key;
    if (lua_type(L, index) == LUA_TSTRING) {
        std::size_t size = 0;
        const char* text = lua_tolstring(L, index, &size);
        key.kind = KeyKind::text;
        key.text = std::string_view(text, size);
    } else if (lua_isinteger(L, index)) {
        key.kind = KeyKind::integer;
        key.integer = lua_tointeger(L, index);
    } else if (lua_type(L, index) == LUA_TNUMBER) {
        const lua_Number number = lua_tonumber(L, index);
        if (std::floor(number) == number && lua_numbertointeger(number, &key.integer))
            key.kind = KeyKind::integer;
    }
    return key;
}

int raw_next(lua_State* L) {
    luaL_checktype(L, 1, LUA_TTABLE);
    lua_settop(L, 2);
    if (lua_next(L, 1) != 0)
        return 2;
    lua_pushnil(L);
    return 1;
}

}  // namespace

void LazyMaps::install(lua_State* L) {
    lua_createtable(L, 0, 5);
    const std::pair<const char*, lua_CFunction> methods[] = {
        {"__index", &LazyMaps::index},
        {"__newindex", &LazyMaps::new_index},
        {"__len", &LazyMaps::length},
        {"__pairs", &LazyMaps::pairs},
    };
    for (const auto& [name, method] : methods) {
        lua_pushlightuserdata(L, this);
        lua_pushcclosure(L, method, 1);
        lua_setfield(L, -2, name);
    }
    lua_pushlightuserdata(L, this);
    lua_pushcclosure(L, &LazyMaps::materialize_method, 1);
    lua_rawsetp(L, -2, &materialize_key);
    metatable_ref_ = luaL_ref(L, LUA_REGISTRYINDEX);
    // What reads a table raw or sees its metatable must see the plain table.
    for (const char* name : {"next", "rawget", "rawset", "rawlen", "getmetatable", "setmetatable"}) {
        if (lua_getglobal(L, name) != LUA_TFUNCTION) {
            lua_pop(L, 1);
            continue;
        }
        lua_pushcclosure(L, &LazyMaps::raw_wrapper, 1);
        lua_setglobal(L, name);
    }
}

bool LazyMaps::push(lua_State* L, std::span<const std::uint8_t> payload) {
    // A definite-length map; whether it is well formed is found by the first read, which scans it
    // all (malformed, it is materialized, and decoding it raises the error).
    CborReader reader{payload.data(), payload.data() + payload.size()};
    CborHead map;
    if (!reader.head(map) || map.major != 5 || map.argument == 0)
        return false;
    lua_createtable(L, 0, 0);
    lua_rawgeti(L, LUA_REGISTRYINDEX, metatable_ref_);
    lua_setmetatable(L, -2);
    current_ = lua_topointer(L, -1);
    payload_ = payload;
    reads_ = 0;
    return true;
}

void LazyMaps::check_current(lua_State* L, int index) const {
    if (current_ == nullptr || lua_topointer(L, index) != current_)
        luaL_error(L,
                   "msg.data of a message whose callbacks are over: its fields are read from the "
                   "message while it is processed (to keep them, copy them, or call pairs on "
                   "msg.data during the callback)");
}

void LazyMaps::materialize(lua_State* L, int index) {
    index = lua_absindex(L, index);
    check_current(L, index);
    luaL_checkstack(L, 4, "materializing msg.data");
    push_cbor(L, payload_);  // the whole map, as the eager decoder builds it
    const int plain = lua_gettop(L);
    lua_pushnil(L);
    while (lua_next(L, plain) != 0) {
        lua_pushvalue(L, -2);
        lua_insert(L, -2);
        lua_rawset(L, index);
    }
    lua_pop(L, 1);
    lua_pushnil(L);
    lua_setmetatable(L, index);
    current_ = nullptr;
}

namespace {

LazyMaps& maps_of(lua_State* L) {
    return *static_cast<LazyMaps*>(lua_touserdata(L, lua_upvalueindex(1)));
}

}  // namespace

int LazyMaps::read_plain(lua_State* L) {
    materialize(L, 1);
    lua_settop(L, 2);
    lua_rawget(L, 1);
    return 1;
}

int LazyMaps::index(lua_State* L) {
    LazyMaps& self = maps_of(L);
    self.check_current(L, 1);
    if (++self.reads_ > max_lazy_reads)
        return self.read_plain(L);
    const LuaKey key = key_at(L, 2);
    if (key.kind == KeyKind::other)
        return self.read_plain(L);
    CborReader reader{self.payload_.data(), self.payload_.data() + self.payload_.size()};
    CborHead map;
    reader.head(map);  // push() saw it
    // Every pair is looked at: with a key twice, the last one counts, as when the map is decoded.
    const std::uint8_t* found = nullptr;
    for (std::uint64_t pair = 0; pair < map.argument; ++pair) {
        CborHead key_head;
        if (!reader.head(key_head))
            return self.read_plain(L);
        bool match = false;
        switch (key_head.major) {
            case 2:  // a blob key and a text key are both a Lua string
            case 3:
                if (key_head.argument > reader.left())
                    return self.read_plain(L);
                match = key.kind == KeyKind::text && key_head.argument == key.text.size() &&
                        std::memcmp(reader.at, key.text.data(), key.text.size()) == 0;
                reader.at += key_head.argument;
                break;
            case 0:
            case 1: {
                if (key_head.argument > static_cast<std::uint64_t>(LUA_MAXINTEGER))
                    return self.read_plain(L);  // a float key once decoded
                const auto magnitude = static_cast<lua_Integer>(key_head.argument);
                const lua_Integer value = key_head.major == 0 ? magnitude : -1 - magnitude;
                match = key.kind == KeyKind::integer && key.integer == value;
                break;
            }
            default:  // floats, booleans, null, tagged keys: the decoder's rules, not repeated here
                return self.read_plain(L);
        }
        const std::uint8_t* value = reader.at;
        if (!reader.skip(0))
            return self.read_plain(L);
        if (match)
            found = value;
    }
    if (reader.at != reader.end)  // bytes after the map: not a payload the decoder takes
        return self.read_plain(L);
    if (found == nullptr) {
        lua_pushnil(L);
        return 1;
    }
    // The most common field, a float64, straight; a map or an array is a table the script may
    // change in place: the plain table holds it.
    if (*found == 0xfb) {
        lua_pushnumber(L, std::bit_cast<double>(proto::read_big_endian(found + 1, 8)));
        return 1;
    }
    const int major = *found >> 5;
    CborReader value{found, reader.end};
    if (major == 4 || major == 5 || !value.push(L, 0))
        return self.read_plain(L);
    return 1;
}

int LazyMaps::new_index(lua_State* L) {
    maps_of(L).materialize(L, 1);
    lua_settop(L, 3);
    lua_rawset(L, 1);
    return 0;
}

int LazyMaps::length(lua_State* L) {
    maps_of(L).materialize(L, 1);
    lua_pushinteger(L, static_cast<lua_Integer>(lua_rawlen(L, 1)));
    return 1;
}

int LazyMaps::pairs(lua_State* L) {
    maps_of(L).materialize(L, 1);
    lua_pushcfunction(L, raw_next);
    lua_pushvalue(L, 1);
    lua_pushnil(L);
    return 3;
}

int LazyMaps::materialize_method(lua_State* L) {
    maps_of(L).materialize(L, 1);
    return 0;
}

int LazyMaps::raw_wrapper(lua_State* L) {
    if (lua_type(L, 1) == LUA_TTABLE)
        materialize_if_lazy(L, 1);
    const int arguments = lua_gettop(L);
    lua_pushvalue(L, lua_upvalueindex(1));
    lua_insert(L, 1);
    lua_call(L, arguments, LUA_MULTRET);
    return lua_gettop(L);
}

void materialize_if_lazy(lua_State* L, int index) {
    index = lua_absindex(L, index);
    if (!lua_getmetatable(L, index))
        return;
    if (lua_rawgetp(L, -1, &materialize_key) != LUA_TFUNCTION) {
        lua_pop(L, 2);
        return;
    }
    lua_remove(L, -2);
    lua_pushvalue(L, index);
    lua_call(L, 1, 0);
}

}  // namespace plexus::daemon::monitor
