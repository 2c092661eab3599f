#include "lua_value.hpp"

#include <bit>
#include <cmath>
#include <cstring>
#include <string_view>

#include "cbor_reader.hpp"
#include "lazy_map.hpp"
#include "plexus/proto/cbor.hpp"

namespace plexus::daemon::monitor {

namespace {

constexpr int max_depth = 64;

/// UTF-8 as RFC 3629 has it: no overlong forms, no surrogates, nothing above U+10FFFF (what a CBOR
/// text string must hold; the decoders of the other side refuse anything else).
bool valid_utf8(std::string_view s) {
    std::size_t i = 0;
    while (i < s.size()) {
        const auto c = static_cast<unsigned char>(s[i]);
        std::size_t extra = 0;
        unsigned char low = 0x80;  // the range of the second byte; the others are 80..bf
        unsigned char high = 0xbf;
        if (c < 0x80) {
            ++i;
            continue;
        }
        if (c >= 0xc2 && c <= 0xdf) {
            extra = 1;
        } else if (c >= 0xe0 && c <= 0xef) {
            extra = 2;
            low = c == 0xe0 ? 0xa0 : 0x80;   // overlong below U+0800
            high = c == 0xed ? 0x9f : 0xbf;  // surrogates U+D800..DFFF
        } else if (c >= 0xf0 && c <= 0xf4) {
            extra = 3;
            low = c == 0xf0 ? 0x90 : 0x80;   // overlong below U+10000
            high = c == 0xf4 ? 0x8f : 0xbf;  // above U+10FFFF
        } else {
            return false;
        }
        if (s.size() - i <= extra)
            return false;
        const auto second = static_cast<unsigned char>(s[i + 1]);
        if (second < low || second > high)
            return false;
        for (std::size_t k = 2; k <= extra; ++k) {
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
    materialize_if_lazy(L, index);  // a lazily decoded msg.data, read raw below
    lua_Integer length = 0;
    if (is_sequence(L, index, length)) {
        if (length == 0 && !(hint && hint->is_array()))
            return nlohmann::json::object();
        auto array = nlohmann::json::array();
        for (lua_Integer i = 1; i <= length; ++i) {
            lua_rawgeti(L, index, i);
            array.push_back(
                convert(L, lua_gettop(L), child_hint(hint, static_cast<std::size_t>(i - 1)), depth + 1));
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

bool CborReader::push(lua_State* L, int depth) {
    if (at >= end || depth > 64 || !lua_checkstack(L, 3))
        return false;
    const std::uint8_t initial = *at++;
    const std::uint8_t major = initial >> 5;
    const std::uint8_t info = initial & 0x1f;
    if (major == 7) {
        switch (info) {
            case 20:
            case 21:
                lua_pushboolean(L, info == 21);
                return true;
            case 22:
            case 23:
                lua_pushnil(L);
                return true;
            default:
                break;
        }
        std::uint64_t bits = 0;
        if (info < 25 || info > 27 || !argument(info, bits))
            return false;
        if (info == 25)
            lua_pushnumber(L, half_to_double(static_cast<std::uint16_t>(bits)));
        else if (info == 26)
            lua_pushnumber(L, std::bit_cast<float>(static_cast<std::uint32_t>(bits)));
        else
            lua_pushnumber(L, std::bit_cast<double>(bits));
        return true;
    }
    std::uint64_t n = 0;
    if (!argument(info, n))
        return false;
    switch (major) {
        case 0:
            if (n <= static_cast<std::uint64_t>(LUA_MAXINTEGER))
                lua_pushinteger(L, static_cast<lua_Integer>(n));
            else
                lua_pushnumber(L, static_cast<lua_Number>(n));
            return true;
        case 1:
            if (n <= static_cast<std::uint64_t>(LUA_MAXINTEGER))
                lua_pushinteger(L, -1 - static_cast<lua_Integer>(n));
            else
                lua_pushnumber(L, -1.0 - static_cast<lua_Number>(n));
            return true;
        case 2:
        case 3:
            if (n > left())
                return false;
            lua_pushlstring(L, reinterpret_cast<const char*>(at), n);
            at += n;
            return true;
        case 4: {
            if (n > left())  // every element takes at least one byte
                return false;
            lua_createtable(L, static_cast<int>(n), 0);
            for (std::uint64_t i = 1; i <= n; ++i) {
                if (!push(L, depth + 1)) {
                    lua_pop(L, 1);
                    return false;
                }
                lua_rawseti(L, -2, static_cast<lua_Integer>(i));
            }
            return true;
        }
        case 5: {
            if (n > left() / 2)
                return false;
            lua_createtable(L, 0, static_cast<int>(n));
            for (std::uint64_t i = 0; i < n; ++i) {
                if (!push(L, depth + 1)) {
                    lua_pop(L, 1);
                    return false;
                }
                if (!push(L, depth + 1)) {
                    lua_pop(L, 2);
                    return false;
                }
                if (lua_isnil(L, -2)) {  // a null key: json cannot have one; drop the pair
                    lua_pop(L, 2);
                    continue;
                }
                lua_rawset(L, -3);
            }
            return true;
        }
        case 6:
            // nlohmann's binary subtype: a tag, then the byte string itself.
            if (info < 24 || info > 27 || at >= end || (*at >> 5) != 2) {
                unusual = true;
                return false;
            }
            return push(L, depth);
        default:
            return false;
    }
}

void push_cbor(lua_State* L, std::span<const std::uint8_t> bytes) {
    const int top = lua_gettop(L);
    CborReader reader{bytes.data(), bytes.data() + bytes.size()};
    if (reader.push(L, 0) && reader.at == reader.end)
        return;
    lua_settop(L, top);
    // The careful decoder takes anything the fast one did not: it either decodes or says why.
    auto decoded = proto::decode_cbor_fast(bytes);
    if (!decoded)
        luaL_error(L, "the payload is not valid CBOR: %s", decoded.error().message.c_str());
    push_json(L, *decoded);
}

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
