// string.rep and string.format, bounded.
//
// rep: the stock loop copies one repetition at a time (16 million memcpy calls for
// string.rep("x", 2^24)), tens of milliseconds with no hook. Ours copies by doubling, in pieces of
// at most a MiB, charging each.
//
// format: each conversion is cheap, but a format string can hold millions of them, and literal text
// is copied one character at a time. The stock function stays the one that formats (its flags,
// widths, %q and %a are intricate); we feed it pieces of a bounded size and charge each.
#include <algorithm>
#include <climits>
#include <cstring>

#include "bounded_functions.hpp"
#include "lua_sandbox.hpp"

namespace plexus::daemon::monitor::bounded {

namespace {

/// Lua's own limit on a string it builds (MAXSIZE in lstrlib.c).
constexpr std::size_t max_result = INT_MAX;
/// Bytes copied between two charges in rep.
constexpr std::size_t copy_piece = 1u << 20;
/// A format up to these sizes goes to the stock function in one call: it is bounded already.
constexpr std::size_t piece_conversions = 64;
constexpr std::size_t piece_text = 4096;
/// What a conversion may cost, in budget steps: a %99.99f of 1e308 prints over 400 digits.
constexpr std::int64_t conversion_cost = 64;
/// %q escapes its string a character at a time in the stock function (6 MB took 30 ms): longer
/// strings are refused rather than quoted unbounded.
constexpr std::size_t max_quoted = 256u * 1024u;
/// string.pack, unpack and packsize: the format's length, and in pack the size of a "cN" field,
/// which the stock function pads with zeros a byte at a time (7 MB took 16 ms).
constexpr std::size_t max_pack_format = 1024;
constexpr lua_Integer max_pack_field = 64 * 1024;

std::int64_t bytes_cost(std::size_t bytes) {
    return 1 + static_cast<std::int64_t>(bytes) / LuaSandbox::bytes_per_step;
}

/// Characters of a conversion between '%' and its letter (flags, width, precision).
bool is_spec_character(char c) {
    return c != '\0' && std::strchr("-+ #0123456789.", c) != nullptr;
}

/// The checks the stock function makes on conversion `conversion`'s argument, made here at the
/// argument's real position, so that an error names the argument as the stock function would.
void check_argument(lua_State* L, int index, int arguments, char conversion) {
    if (index > arguments)
        luaL_argerror(L, index, "no value");
    switch (conversion) {
        case 'c':
        case 'd':
        case 'i':
        case 'u':
        case 'o':
        case 'x':
        case 'X':
            luaL_checkinteger(L, index);
            break;
        case 'a':
        case 'A':
        case 'e':
        case 'E':
        case 'f':
        case 'F':
        case 'g':
        case 'G':
            luaL_checknumber(L, index);
            break;
        case 'q': {
            const int type = lua_type(L, index);
            if (type != LUA_TSTRING && type != LUA_TNUMBER && type != LUA_TNIL && type != LUA_TBOOLEAN)
                luaL_argerror(L, index, "value has no literal form");
            if (type == LUA_TSTRING && lua_rawlen(L, index) > max_quoted)
                luaL_argerror(L, index, "string too long for '%q' in the sandbox (over 256 KiB)");
            break;
        }
        default:
            break;  // 's' and 'p' take anything; an invalid conversion is the stock function's error
    }
}

}  // namespace

int string_rep(lua_State* L) {
    std::size_t size = 0;
    std::size_t separator_size = 0;
    const char* s = luaL_checklstring(L, 1, &size);
    const lua_Integer n = luaL_checkinteger(L, 2);
    const char* separator = luaL_optlstring(L, 3, "", &separator_size);
    if (n <= 0) {
        lua_pushliteral(L, "");
        return 1;
    }
    const std::size_t unit = size + separator_size;
    if (unit < size || unit > max_result / static_cast<std::size_t>(n))
        return luaL_error(L, "resulting string too large");
    const std::size_t total =
        static_cast<std::size_t>(n) * size + static_cast<std::size_t>(n - 1) * separator_size;
    luaL_Buffer buffer;
    char* out = luaL_buffinitsize(L, &buffer, total);
    // One repetition with its separator (the last one has none), then the filled part doubles,
    // which keeps it a whole number of repetitions until the last piece.
    std::memcpy(out, s, size);
    std::size_t filled = size;
    if (n > 1) {
        std::memcpy(out + size, separator, separator_size);
        filled = unit;
    }
    LuaSandbox::charge(L, bytes_cost(filled));
    const std::size_t longest = std::max(unit, copy_piece / std::max<std::size_t>(unit, 1) * unit);
    while (filled < total) {
        const std::size_t piece = std::min({filled, total - filled, longest});
        std::memcpy(out + filled, out, piece);
        filled += piece;
        LuaSandbox::charge(L, bytes_cost(piece));
    }
    luaL_pushresultsize(&buffer, total);
    return 1;
}

int string_format(lua_State* L) {
    std::size_t size = 0;
    const char* format = luaL_checklstring(L, 1, &size);
    const auto percents = static_cast<std::size_t>(std::count(format, format + size, '%'));
    // %q goes the long way, where its string's size is checked.
    const bool quotes = std::memchr(format, 'q', size) != nullptr;
    if (size <= piece_text && percents <= piece_conversions && !quotes) {
        // The usual case: small enough for one call. The stock function runs in this very call
        // frame, so everything (errors and their argument numbers included) is exactly Lua's.
        LuaSandbox::charge(L, bytes_cost(size) + conversion_cost * static_cast<std::int64_t>(percents));
        return lua_tocfunction(L, lua_upvalueindex(1))(L);
    }
    const int arguments = lua_gettop(L);  // before the buffer takes a slot
    luaL_Buffer out;
    luaL_buffinit(L, &out);
    int next_argument = 2;
    std::size_t position = 0;
    while (position < size) {
        // One piece: up to piece_conversions conversions and piece_text bytes, never cut inside a
        // conversion or a "%%".
        const std::size_t start = position;
        std::size_t conversions = 0;
        while (position < size && conversions < piece_conversions && position - start < piece_text) {
            if (format[position] != '%') {
                const std::size_t limit = std::min(size, start + piece_text);
                const auto* percent =
                    static_cast<const char*>(std::memchr(format + position, '%', limit - position));
                position = percent ? static_cast<std::size_t>(percent - format) : limit;
                continue;
            }
            if (position + 1 < size && format[position + 1] == '%') {
                position += 2;
                continue;
            }
            std::size_t letter = position + 1;
            while (letter < size && is_spec_character(format[letter]))
                ++letter;
            check_argument(L, next_argument + static_cast<int>(conversions), arguments,
                           letter < size ? format[letter] : '\0');
            position = std::min(letter + 1, size);
            ++conversions;
        }
        LuaSandbox::charge(
            L, bytes_cost(position - start) + conversion_cost * static_cast<std::int64_t>(conversions));
        const int count = static_cast<int>(conversions);
        lua_pushvalue(L, lua_upvalueindex(1));
        lua_pushlstring(L, format + start, position - start);
        for (int i = 0; i < count; ++i)
            lua_pushvalue(L, next_argument + i);
        lua_call(L, count + 1, 1);
        luaL_addvalue(&out);
        next_argument += count;
    }
    luaL_pushresult(&out);
    return 1;
}

int string_pack(lua_State* L) {
    std::size_t size = 0;
    const char* format = luaL_checklstring(L, 1, &size);
    if (size > max_pack_format)
        luaL_argerror(L, 1, "format longer than the sandbox's 1024 bytes");
    for (std::size_t i = 0; i < size; ++i) {
        if (format[i] != 'c')
            continue;
        lua_Integer field = 0;
        while (i + 1 < size && format[i + 1] >= '0' && format[i + 1] <= '9' && field <= max_pack_field)
            field = field * 10 + (format[++i] - '0');
        if (field > max_pack_field)
            luaL_argerror(L, 1, "a 'cN' field over the sandbox's 65536 bytes");
    }
    LuaSandbox::charge(L, bytes_cost(size) + lua_gettop(L));
    return lua_tocfunction(L, lua_upvalueindex(1))(L);
}

int string_unpack_or_packsize(lua_State* L) {
    std::size_t size = 0;
    luaL_checklstring(L, 1, &size);
    if (size > max_pack_format)
        luaL_argerror(L, 1, "format longer than the sandbox's 1024 bytes");
    LuaSandbox::charge(L, bytes_cost(size));
    return lua_tocfunction(L, lua_upvalueindex(1))(L);
}

}  // namespace plexus::daemon::monitor::bounded
