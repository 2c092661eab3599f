#include "lua_value.hpp"

#include <cmath>
#include <string_view>

namespace plexus::daemon::monitor {

namespace {

constexpr int max_depth = 64;

bool valid_utf8(std::string_view s) {
    std::size_t i = 0;
    while (i < s.size()) {
        const auto c = static_cast<unsigned char>(s[i]);
        std::size_t extra = 0;
        if (c < 0x80)
            extra = 0;
        else if ((c & 0xe0) == 0xc0 && c >= 0xc2)
            extra = 1;
        else if ((c & 0xf0) == 0xe0)
            extra = 2;
        else if ((c & 0xf8) == 0xf0 && c <= 0xf4)
            extra = 3;
        else
            return false;
        if (i + extra >= s.size() && extra > 0)
            return false;
        for (std::size_t k = 1; k <= extra; ++k) {
            if ((static_cast<unsigned char>(s[i + k]) & 0xc0) != 0x80)
                return false;
        }
        i += extra + 1;
    }
    return true;
}

/// A table is an array when its keys are exactly 1..n.
bool is_sequence(lua_State* L, int index, lua_Integer& length) {
    length = static_cast<lua_Integer>(lua_rawlen(L, index));
    lua_Integer count = 0;
    lua_pushnil(L);
    while (lua_next(L, index) != 0) {
        lua_pop(L, 1);
        if (!lua_isinteger(L, -1)) {
            lua_pop(L, 1);
            return false;
        }
        const lua_Integer key = lua_tointeger(L, -1);
        if (key < 1 || key > length) {
            lua_pop(L, 1);
            return false;
        }
        ++count;
    }
    return count == length;
}

const nlohmann::json* child_hint(const nlohmann::json* hint, std::size_t i) {
    if (hint && hint->is_array() && i < hint->size())
        return &(*hint)[i];
    return nullptr;
}

const nlohmann::json* child_hint(const nlohmann::json* hint, const std::string& key) {
    if (!hint || !hint->is_object())
        return nullptr;
    auto it = hint->find(key);
    return it == hint->end() ? nullptr : &*it;
}

nlohmann::json convert(lua_State* L, int index, const nlohmann::json* hint, int depth);

nlohmann::json convert_table(lua_State* L, int index, const nlohmann::json* hint, int depth) {
    if (depth > max_depth)
        luaL_error(L, "value nested deeper than %d levels (a cycle?)", max_depth);
    luaL_checkstack(L, 4, "value too deep");
    lua_Integer length = 0;
    if (is_sequence(L, index, length)) {
        if (length == 0 && !(hint && hint->is_array()))
            return nlohmann::json::object();
        auto array = nlohmann::json::array();
        for (lua_Integer i = 1; i <= length; ++i) {
            lua_rawgeti(L, index, i);
            array.push_back(convert(L, lua_gettop(L), child_hint(hint, static_cast<std::size_t>(i - 1)), depth + 1));
            lua_pop(L, 1);
        }
        return array;
    }
    auto object = nlohmann::json::object();
    lua_pushnil(L);
    while (lua_next(L, index) != 0) {
        std::string key;
        if (lua_type(L, -2) == LUA_TSTRING) {
            std::size_t n = 0;
            const char* s = lua_tolstring(L, -2, &n);
            key.assign(s, n);
        } else if (lua_type(L, -2) == LUA_TNUMBER) {
            lua_pushvalue(L, -2);  // tostring on a copy: lua_next needs the key unchanged
            key = lua_tostring(L, -1);
            lua_pop(L, 1);
        } else {
            luaL_error(L, "cannot encode a table key of type %s", luaL_typename(L, -2));
        }
        object[key] = convert(L, lua_gettop(L), child_hint(hint, key), depth + 1);
        lua_pop(L, 1);
    }
    return object;
}

nlohmann::json convert(lua_State* L, int index, const nlohmann::json* hint, int depth) {
    switch (lua_type(L, index)) {
        case LUA_TNIL:
            return nullptr;
        case LUA_TBOOLEAN:
            return lua_toboolean(L, index) != 0;
        case LUA_TNUMBER:
            if (lua_isinteger(L, index)) {
                const lua_Integer i = lua_tointeger(L, index);
                if (hint && hint->is_number_unsigned() && i >= 0)
                    return static_cast<std::uint64_t>(i);
                return static_cast<std::int64_t>(i);
            }
            return static_cast<double>(lua_tonumber(L, index));
        case LUA_TSTRING: {
            std::size_t n = 0;
            const char* s = lua_tolstring(L, index, &n);
            std::string_view text(s, n);
            if ((hint && hint->is_binary()) || !valid_utf8(text)) {
                const auto* bytes = reinterpret_cast<const std::uint8_t*>(s);
                return nlohmann::json::binary(std::vector<std::uint8_t>(bytes, bytes + n));
            }
            return std::string(text);
        }
        case LUA_TTABLE:
            return convert_table(L, index, hint, depth);
        default:
            luaL_error(L, "cannot encode a value of type %s", luaL_typename(L, index));
            return nullptr;
    }
}

}  // namespace

void push_json(lua_State* L, const nlohmann::json& value) {
    luaL_checkstack(L, 3, "value too deep");
    switch (value.type()) {
        case nlohmann::json::value_t::null:
        case nlohmann::json::value_t::discarded:
            lua_pushnil(L);
            return;
        case nlohmann::json::value_t::boolean:
            lua_pushboolean(L, value.get<bool>() ? 1 : 0);
            return;
        case nlohmann::json::value_t::number_integer:
            lua_pushinteger(L, value.get<std::int64_t>());
            return;
        case nlohmann::json::value_t::number_unsigned: {
            const auto u = value.get<std::uint64_t>();
            if (u <= static_cast<std::uint64_t>(LUA_MAXINTEGER))
                lua_pushinteger(L, static_cast<lua_Integer>(u));
            else
                lua_pushnumber(L, static_cast<lua_Number>(u));
            return;
        }
        case nlohmann::json::value_t::number_float:
            lua_pushnumber(L, value.get<double>());
            return;
        case nlohmann::json::value_t::string: {
            const auto& s = value.get_ref<const std::string&>();
            lua_pushlstring(L, s.data(), s.size());
            return;
        }
        case nlohmann::json::value_t::binary: {
            const auto& b = value.get_binary();
            lua_pushlstring(L, reinterpret_cast<const char*>(b.data()), b.size());
            return;
        }
        case nlohmann::json::value_t::array: {
            lua_createtable(L, static_cast<int>(value.size()), 0);
            lua_Integer i = 1;
            for (const auto& element : value) {
                push_json(L, element);
                lua_rawseti(L, -2, i++);
            }
            return;
        }
        case nlohmann::json::value_t::object: {
            lua_createtable(L, 0, static_cast<int>(value.size()));
            for (const auto& [key, element] : value.items()) {
                lua_pushlstring(L, key.data(), key.size());
                push_json(L, element);
                lua_rawset(L, -3);
            }
            return;
        }
    }
    lua_pushnil(L);
}

nlohmann::json to_json(lua_State* L, int index, const nlohmann::json* hint) {
    return convert(L, lua_absindex(L, index), hint, 0);
}

}  // namespace plexus::daemon::monitor
