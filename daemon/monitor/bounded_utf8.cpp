// utf8.len, offset, codepoint and codes, bounded: each walks a string that may be as large as the
// memory cap, byte by byte, in C. Ours walk the same way and charge a step per few bytes; the
// decoding rules (strict or lax, the limits on overlong forms) are Lua 5.4's.
#include <climits>
#include <cstdint>

#include "bounded_functions.hpp"
#include "lua_sandbox.hpp"

namespace plexus::daemon::monitor::bounded {

namespace {

constexpr std::uint32_t max_unicode = 0x10FFFFu;
constexpr std::uint32_t max_utf = 0x7FFFFFFFu;
constexpr const char* invalid_code = "invalid UTF-8 code";

bool is_continuation(const char* p) {
    return (static_cast<unsigned char>(*p) & 0xC0) == 0x80;
}

/// Lua's u_posrelat: negative positions count from the end; too negative gives 0.
lua_Integer relative_position(lua_Integer position, std::size_t size) {
    if (position >= 0)
        return position;
    if (0u - static_cast<std::size_t>(position) > size)
        return 0;
    return static_cast<lua_Integer>(size) + position + 1;
}

/// Decodes one sequence at `s` (the string's NUL ends any sequence cut short); null if invalid.
const char* decode(const char* s, std::uint32_t* value, bool strict) {
    static const std::uint32_t smallest[] = {~std::uint32_t{0}, 0x80, 0x800, 0x10000u, 0x200000u, 0x4000000u};
    unsigned int c = static_cast<unsigned char>(s[0]);
    std::uint32_t result = 0;
    if (c < 0x80) {
        result = c;
    } else {
        int count = 0;
        for (; c & 0x40; c <<= 1) {
            const unsigned int next = static_cast<unsigned char>(s[++count]);
            if ((next & 0xC0) != 0x80)
                return nullptr;
            result = (result << 6) | (next & 0x3F);
        }
        result |= static_cast<std::uint32_t>(c & 0x7F) << (count * 5);
        if (count > 5 || result > max_utf || result < smallest[count])
            return nullptr;
        s += count;
    }
    if (strict && (result > max_unicode || (0xD800u <= result && result <= 0xDFFFu)))
        return nullptr;
    if (value)
        *value = result;
    return s + 1;
}

void step(lua_State* L) {
    LuaSandbox::charge(L, 1);
}

int codes_next(lua_State* L, bool strict) {
    std::size_t size = 0;
    const char* s = luaL_checklstring(L, 1, &size);
    auto n = static_cast<lua_Unsigned>(lua_tointeger(L, 2));
    if (n < size) {
        while (is_continuation(s + n)) {  // skip the rest of the current character
            step(L);
            ++n;
        }
    }
    if (n >= size)
        return 0;
    std::uint32_t code = 0;
    const char* next = decode(s + n, &code, strict);
    if (!next)
        return luaL_error(L, invalid_code);
    lua_pushinteger(L, static_cast<lua_Integer>(n) + 1);
    lua_pushinteger(L, code);
    return 2;
}

int codes_next_strict(lua_State* L) {
    return codes_next(L, true);
}
int codes_next_lax(lua_State* L) {
    return codes_next(L, false);
}

}  // namespace

int utf8_len(lua_State* L) {
    std::size_t size = 0;
    const char* s = luaL_checklstring(L, 1, &size);
    lua_Integer first = relative_position(luaL_optinteger(L, 2, 1), size);
    lua_Integer last = relative_position(luaL_optinteger(L, 3, -1), size);
    const bool lax = lua_toboolean(L, 4);
    luaL_argcheck(L, 1 <= first && --first <= static_cast<lua_Integer>(size), 2,
                  "initial position out of bounds");
    luaL_argcheck(L, --last < static_cast<lua_Integer>(size), 3, "final position out of bounds");
    lua_Integer count = 0;
    while (first <= last) {
        step(L);
        const char* next = decode(s + first, nullptr, !lax);
        if (!next) {
            luaL_pushfail(L);
            lua_pushinteger(L, first + 1);
            return 2;
        }
        first = next - s;
        ++count;
    }
    lua_pushinteger(L, count);
    return 1;
}

int utf8_codepoint(lua_State* L) {
    std::size_t size = 0;
    const char* s = luaL_checklstring(L, 1, &size);
    const lua_Integer first = relative_position(luaL_optinteger(L, 2, 1), size);
    const lua_Integer last = relative_position(luaL_optinteger(L, 3, first), size);
    const bool lax = lua_toboolean(L, 4);
    luaL_argcheck(L, first >= 1, 2, "out of bounds");
    luaL_argcheck(L, last <= static_cast<lua_Integer>(size), 3, "out of bounds");
    if (first > last)
        return 0;
    if (last - first >= INT_MAX)
        return luaL_error(L, "string slice too long");
    luaL_checkstack(L, static_cast<int>(last - first) + 1, "string slice too long");
    int count = 0;
    const char* end = s + last;
    for (s += first - 1; s < end;) {
        step(L);
        std::uint32_t code = 0;
        s = decode(s, &code, !lax);
        if (!s)
            return luaL_error(L, invalid_code);
        lua_pushinteger(L, code);
        ++count;
    }
    return count;
}

int utf8_offset(lua_State* L) {
    std::size_t size = 0;
    const char* s = luaL_checklstring(L, 1, &size);
    lua_Integer n = luaL_checkinteger(L, 2);
    const lua_Integer default_start = n >= 0 ? 1 : static_cast<lua_Integer>(size) + 1;
    lua_Integer position = relative_position(luaL_optinteger(L, 3, default_start), size);
    luaL_argcheck(L, 1 <= position && --position <= static_cast<lua_Integer>(size), 3,
                  "position out of bounds");
    if (n == 0) {
        while (position > 0 && is_continuation(s + position)) {  // back to the start of this character
            step(L);
            --position;
        }
    } else {
        if (is_continuation(s + position))
            return luaL_error(L, "initial position is a continuation byte");
        if (n < 0) {
            while (n < 0 && position > 0) {
                do {
                    step(L);
                    --position;
                } while (position > 0 && is_continuation(s + position));
                ++n;
            }
        } else {
            --n;  // the first character is where we are
            while (n > 0 && position < static_cast<lua_Integer>(size)) {
                do {
                    step(L);
                    ++position;
                } while (is_continuation(s + position));  // the string's NUL stops it
                --n;
            }
        }
    }
    if (n == 0)
        lua_pushinteger(L, position + 1);
    else
        luaL_pushfail(L);
    return 1;
}

int utf8_codes(lua_State* L) {
    const bool lax = lua_toboolean(L, 2);
    luaL_checkstring(L, 1);
    lua_pushcfunction(L, lax ? codes_next_lax : codes_next_strict);
    lua_pushvalue(L, 1);
    lua_pushinteger(L, 0);
    return 3;
}

}  // namespace plexus::daemon::monitor::bounded
