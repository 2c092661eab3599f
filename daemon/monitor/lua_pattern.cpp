// string.find, match, gmatch and gsub with Lua 5.4's pattern semantics, on a matcher that charges
// every step to the sandbox's time budget. The stock matcher backtracks without limit inside C:
// string.find(string.rep("a", 30000), ".-.-.-b") runs for minutes and no hook fires. This one
// backtracks the same way (so it finds the same matches and captures, and raises the same errors),
// but every call of `match` and every character a quantifier tries costs a step, and the clock is
// read every LuaSandbox::steps_per_check steps.
#include <cctype>
#include <cstddef>
#include <cstring>
#include <new>

#include "bounded_functions.hpp"
#include "lua_sandbox.hpp"

namespace plexus::daemon::monitor::bounded {

namespace {

constexpr char escape = '%';
/// LUA_MAXCAPTURES, a constant of lstrlib.c (luaconf.h does not export it).
constexpr int max_captures = 32;
/// Nested calls of `match` before "pattern too complex": Lua's own limit (MAXCCALLS in lstrlib.c),
/// which also keeps the C stack small.
constexpr int max_depth = 200;
constexpr std::ptrdiff_t capture_unfinished = -1;
constexpr std::ptrdiff_t capture_position = -2;

unsigned char byte_at(const char* p) {
    return static_cast<unsigned char>(*p);
}

/// One %x class: letters select a <cctype> test (an upper-case letter negates it); anything else
/// stands for itself.
bool class_matches(int c, int class_letter) {
    bool result = false;
    switch (std::tolower(class_letter)) {
        case 'a':
            result = std::isalpha(c);
            break;
        case 'c':
            result = std::iscntrl(c);
            break;
        case 'd':
            result = std::isdigit(c);
            break;
        case 'g':
            result = std::isgraph(c);
            break;
        case 'l':
            result = std::islower(c);
            break;
        case 'p':
            result = std::ispunct(c);
            break;
        case 's':
            result = std::isspace(c);
            break;
        case 'u':
            result = std::isupper(c);
            break;
        case 'w':
            result = std::isalnum(c);
            break;
        case 'x':
            result = std::isxdigit(c);
            break;
        case 'z':
            result = c == 0;
            break;  // deprecated, but Lua 5.4 still has it
        default:
            return class_letter == c;
    }
    return std::isupper(class_letter) ? !result : result;
}

/// A set [...]: `p` at its '[', `last` at its closing ']'.
bool set_matches(int c, const char* p, const char* last) {
    bool wanted = true;
    if (p[1] == '^') {
        wanted = false;
        ++p;
    }
    while (++p < last) {
        if (*p == escape) {
            ++p;
            if (class_matches(c, byte_at(p)))
                return wanted;
        } else if (p[1] == '-' && p + 2 < last) {
            p += 2;
            if (byte_at(p - 2) <= c && c <= byte_at(p))
                return wanted;
        } else if (byte_at(p) == c) {
            return wanted;
        }
    }
    return !wanted;
}

class Matcher {
public:
    Matcher(lua_State* L, const char* subject, std::size_t subject_size, const char* pattern,
            std::size_t pattern_size)
        : L_(L),
          subject_(subject),
          subject_end_(subject + subject_size),
          pattern_end_(pattern + pattern_size) {}

    void set_state(lua_State* L) { L_ = L; }
    /// Before each attempt at a new position.
    void reset() {
        level_ = 0;
        depth_left_ = max_depth;
    }
    const char* subject_end() const { return subject_end_; }

    /// The end of the match of pattern `p` at subject position `s`, or null.
    const char* match(const char* s, const char* p) {
        if (depth_left_-- == 0)
            luaL_error(L_, "pattern too complex");
        s = match_here(s, p);
        ++depth_left_;
        return s;
    }

    /// Pushes the captures (the whole match [s, e) when there are none and `s` is not null).
    int push_captures(const char* s, const char* e) {
        const int count = (level_ == 0 && s) ? 1 : level_;
        luaL_checkstack(L_, count, "too many captures");
        for (int i = 0; i < count; ++i)
            push_capture(i, s, e);
        return count;
    }

    /// Capture `i` as text: its start in `*start` and its size, or capture_position after pushing
    /// the position (as an integer) on the stack.
    std::ptrdiff_t capture(int i, const char* s, const char* e, const char** start) {
        if (i >= level_) {
            if (i != 0)
                luaL_error(L_, "invalid capture index %%%d", i + 1);
            *start = s;
            return e - s;
        }
        const std::ptrdiff_t size = captures_[i].size;
        *start = captures_[i].start;
        if (size == capture_unfinished)
            luaL_error(L_, "unfinished capture");
        else if (size == capture_position)
            lua_pushinteger(L_, (captures_[i].start - subject_) + 1);
        return size;
    }

    void push_capture(int i, const char* s, const char* e) {
        const char* start = nullptr;
        const std::ptrdiff_t size = capture(i, s, e, &start);
        if (size != capture_position)
            lua_pushlstring(L_, start, static_cast<std::size_t>(size));
    }

private:
    struct Capture {
        const char* start;
        std::ptrdiff_t size;
    };

    void step() { LuaSandbox::charge(L_, 1); }

    /// The end of the single-character class at `p` (a char, '.', %x or a set).
    const char* class_end(const char* p) {
        switch (*p++) {
            case escape:
                if (p == pattern_end_)
                    luaL_error(L_, "malformed pattern (ends with '%%')");
                return p + 1;
            case '[':
                if (p < pattern_end_ && *p == '^')
                    ++p;
                // The first character of a set is never its end: "[]]" is a set of one ']'.
                do {
                    if (p == pattern_end_)
                        luaL_error(L_, "malformed pattern (missing ']')");
                    if (*p++ == escape && p < pattern_end_)
                        ++p;
                } while (p == pattern_end_ || *p != ']');
                return p + 1;
            default:
                return p;
        }
    }

    bool single_matches(const char* s, const char* p, const char* class_end) const {
        if (s >= subject_end_)
            return false;
        const int c = byte_at(s);
        switch (*p) {
            case '.':
                return true;
            case escape:
                return class_matches(c, byte_at(p + 1));
            case '[':
                return set_matches(c, p, class_end - 1);
            default:
                return byte_at(p) == c;
        }
    }

    const char* match_here(const char* s, const char* p) {
        for (;;) {
            step();
            if (p == pattern_end_)
                return s;
            const bool more = p + 1 < pattern_end_;
            switch (*p) {
                case '(':
                    if (more && p[1] == ')')
                        return start_capture(s, p + 2, capture_position);
                    return start_capture(s, p + 1, capture_unfinished);
                case ')':
                    return end_capture(s, p + 1);
                case '$':
                    if (!more)
                        return s == subject_end_ ? s : nullptr;
                    break;  // elsewhere '$' is an ordinary character
                case escape:
                    if (more && p[1] == 'b') {
                        s = match_balance(s, p + 2);
                        if (!s)
                            return nullptr;
                        p += 4;
                        continue;
                    }
                    if (more && p[1] == 'f') {
                        p += 2;
                        if (p == pattern_end_ || *p != '[')
                            luaL_error(L_, "missing '[' after '%%f' in pattern");
                        const char* end = class_end(p);
                        const int before = s == subject_ ? '\0' : byte_at(s - 1);
                        const int here = s < subject_end_ ? byte_at(s) : '\0';
                        if (set_matches(before, p, end - 1) || !set_matches(here, p, end - 1))
                            return nullptr;
                        p = end;
                        continue;
                    }
                    if (more && std::isdigit(byte_at(p + 1))) {
                        s = match_back_reference(s, byte_at(p + 1));
                        if (!s)
                            return nullptr;
                        p += 2;
                        continue;
                    }
                    break;
                default:
                    break;
            }
            const char* end = class_end(p);
            const char quantifier = end < pattern_end_ ? *end : '\0';
            if (!single_matches(s, p, end)) {
                if (quantifier == '*' || quantifier == '?' || quantifier == '-') {
                    p = end + 1;  // zero repetitions are allowed
                    continue;
                }
                return nullptr;
            }
            switch (quantifier) {
                case '?': {
                    if (const char* result = match(s + 1, end + 1))
                        return result;
                    p = end + 1;
                    continue;
                }
                case '+':
                    return max_expand(s + 1, p, end);
                case '*':
                    return max_expand(s, p, end);
                case '-':
                    return min_expand(s, p, end);
                default:
                    ++s;
                    p = end;
                    continue;
            }
        }
    }

    /// Greedy: as many as match, then back off one at a time.
    const char* max_expand(const char* s, const char* p, const char* end) {
        std::ptrdiff_t count = 0;
        while (single_matches(s + count, p, end)) {
            step();
            ++count;
        }
        for (; count >= 0; --count) {
            if (const char* result = match(s + count, end + 1))
                return result;
        }
        return nullptr;
    }

    /// Lazy: as few as possible, one more at a time.
    const char* min_expand(const char* s, const char* p, const char* end) {
        for (;;) {
            if (const char* result = match(s, end + 1))
                return result;
            if (!single_matches(s, p, end))
                return nullptr;
            ++s;
        }
    }

    const char* start_capture(const char* s, const char* p, std::ptrdiff_t what) {
        if (level_ >= max_captures)
            luaL_error(L_, "too many captures");
        captures_[level_] = Capture{s, what};
        ++level_;
        const char* result = match(s, p);
        if (!result)
            --level_;
        return result;
    }

    const char* end_capture(const char* s, const char* p) {
        const int open = innermost_open_capture();
        captures_[open].size = s - captures_[open].start;
        const char* result = match(s, p);
        if (!result)
            captures_[open].size = capture_unfinished;
        return result;
    }

    int innermost_open_capture() {
        for (int level = level_ - 1; level >= 0; --level) {
            if (captures_[level].size == capture_unfinished)
                return level;
        }
        return luaL_error(L_, "invalid pattern capture");
    }

    /// %bxy: a balanced run from an x to its matching y.
    const char* match_balance(const char* s, const char* p) {
        if (p >= pattern_end_ - 1)
            luaL_error(L_, "malformed pattern (missing arguments to '%%b')");
        if (s >= subject_end_ || *s != *p)
            return nullptr;
        const char open = p[0];
        const char close = p[1];
        int depth = 1;
        while (++s < subject_end_) {
            step();
            if (*s == close) {
                if (--depth == 0)
                    return s + 1;
            } else if (*s == open) {
                ++depth;
            }
        }
        return nullptr;
    }

    /// %1..%9: the text of an earlier, closed capture again.
    const char* match_back_reference(const char* s, int digit) {
        const int i = digit - '1';
        if (i < 0 || i >= level_ || captures_[i].size == capture_unfinished)
            luaL_error(L_, "invalid capture index %%%d", i + 1);
        // A position capture has a negative size: as an unsigned size it never fits, as in Lua.
        const auto size = static_cast<std::size_t>(captures_[i].size);
        if (static_cast<std::size_t>(subject_end_ - s) >= size) {
            LuaSandbox::charge(L_, 1 + static_cast<std::int64_t>(size) / LuaSandbox::bytes_per_step);
            if (std::memcmp(captures_[i].start, s, size) == 0)
                return s + size;
        }
        return nullptr;
    }

    lua_State* L_;
    const char* subject_;
    const char* subject_end_;
    const char* pattern_end_;
    int level_ = 0;
    int depth_left_ = max_depth;
    Capture captures_[max_captures];
};

/// Lua's posrelatI: a start position, 1-based, negative from the end, clamped to at least 1.
std::size_t start_position(lua_Integer position, std::size_t size) {
    if (position > 0)
        return static_cast<std::size_t>(position);
    if (position == 0)
        return 1;
    if (position < -static_cast<lua_Integer>(size))
        return 1;
    return size + static_cast<std::size_t>(position) + 1;
}

bool has_specials(const char* p, std::size_t size) {
    for (std::size_t i = 0; i < size; ++i) {
        if (p[i] != '\0' && std::strchr("^$*+?.([%-", p[i]))
            return true;
    }
    return false;
}

/// A plain substring search. memchr + memcmp like Lua's, so it is O(subject x needle) at worst:
/// each comparison is charged by the needle's size.
const char* find_plain(lua_State* L, const char* s, std::size_t size, const char* needle,
                       std::size_t needle_size) {
    if (needle_size == 0)
        return s;
    if (needle_size > size)
        return nullptr;
    const std::int64_t compare_cost = 1 + static_cast<std::int64_t>(needle_size) / LuaSandbox::bytes_per_step;
    const char* end = s + (size - needle_size) + 1;  // the last place a match can start, plus one
    while (s < end) {
        const auto* hit =
            static_cast<const char*>(std::memchr(s, *needle, static_cast<std::size_t>(end - s)));
        if (!hit)
            return nullptr;
        LuaSandbox::charge(L, compare_cost + (hit - s) / LuaSandbox::bytes_per_step);
        if (std::memcmp(hit + 1, needle + 1, needle_size - 1) == 0)
            return hit;
        s = hit + 1;
    }
    return nullptr;
}

int find_or_match(lua_State* L, bool find) {
    std::size_t subject_size = 0;
    std::size_t pattern_size = 0;
    const char* s = luaL_checklstring(L, 1, &subject_size);
    const char* p = luaL_checklstring(L, 2, &pattern_size);
    const std::size_t init = start_position(luaL_optinteger(L, 3, 1), subject_size) - 1;
    if (init > subject_size) {
        luaL_pushfail(L);
        return 1;
    }
    if (find && (lua_toboolean(L, 4) || !has_specials(p, pattern_size))) {
        if (const char* found = find_plain(L, s + init, subject_size - init, p, pattern_size)) {
            lua_pushinteger(L, (found - s) + 1);
            lua_pushinteger(L, (found - s) + static_cast<lua_Integer>(pattern_size));
            return 2;
        }
        luaL_pushfail(L);
        return 1;
    }
    const bool anchored = pattern_size > 0 && *p == '^';
    if (anchored) {
        ++p;
        --pattern_size;
    }
    Matcher matcher(L, s, subject_size, p, pattern_size);
    const char* start = s + init;
    do {
        matcher.reset();
        if (const char* end = matcher.match(start, p)) {
            if (find) {
                lua_pushinteger(L, (start - s) + 1);
                lua_pushinteger(L, end - s);
                return matcher.push_captures(nullptr, nullptr) + 2;
            }
            return matcher.push_captures(start, end);
        }
    } while (start++ < matcher.subject_end() && !anchored);
    luaL_pushfail(L);
    return 1;
}

/// What a gmatch iterator keeps between calls (a userdata: trivially destructible).
struct GmatchState {
    Matcher matcher;
    const char* next;  ///< where the next search starts
    const char* pattern;
    const char* last_match;  ///< the end of the last match: an empty match there is skipped
};

int gmatch_next(lua_State* L) {
    auto* state = static_cast<GmatchState*>(lua_touserdata(L, lua_upvalueindex(3)));
    state->matcher.set_state(L);
    for (const char* s = state->next; s <= state->matcher.subject_end(); ++s) {
        state->matcher.reset();
        const char* end = state->matcher.match(s, state->pattern);
        if (end && end != state->last_match) {
            state->next = state->last_match = end;
            return state->matcher.push_captures(s, end);
        }
    }
    return 0;
}

/// Appends the replacement string (argument 3) for the match [s, e), with %0-%9 and %%.
void add_replacement_string(lua_State* L, Matcher& matcher, luaL_Buffer& out, const char* s, const char* e) {
    std::size_t size = 0;
    const char* text = lua_tolstring(L, 3, &size);
    LuaSandbox::charge(L, 1 + static_cast<std::int64_t>(size) / LuaSandbox::bytes_per_step);
    const char* p = nullptr;
    while ((p = static_cast<const char*>(std::memchr(text, escape, size))) != nullptr) {
        luaL_addlstring(&out, text, static_cast<std::size_t>(p - text));
        ++p;  // the character after '%' (the string's terminating NUL when '%' ends it)
        if (*p == escape) {
            luaL_addchar(&out, *p);
        } else if (*p == '0') {
            luaL_addlstring(&out, s, static_cast<std::size_t>(e - s));
        } else if (std::isdigit(byte_at(p))) {
            const char* start = nullptr;
            const std::ptrdiff_t captured = matcher.capture(*p - '1', s, e, &start);
            if (captured == capture_position)
                luaL_addvalue(&out);  // the position the capture pushed
            else
                luaL_addlstring(&out, start, static_cast<std::size_t>(captured));
        } else {
            luaL_error(L, "invalid use of '%c' in replacement string", escape);
        }
        size -= static_cast<std::size_t>(p + 1 - text);
        text = p + 1;
    }
    luaL_addlstring(&out, text, size);
}

/// Appends the replacement for the match [s, e); false when the match is kept as it was.
bool add_replacement(lua_State* L, Matcher& matcher, luaL_Buffer& out, const char* s, const char* e,
                     int replacement_type) {
    switch (replacement_type) {
        case LUA_TFUNCTION: {
            lua_pushvalue(L, 3);
            const int count = matcher.push_captures(s, e);
            lua_call(L, count, 1);
            break;
        }
        case LUA_TTABLE:
            matcher.push_capture(0, s, e);
            lua_gettable(L, 3);
            break;
        default:
            add_replacement_string(L, matcher, out, s, e);
            return true;
    }
    if (!lua_toboolean(L, -1)) {
        lua_pop(L, 1);
        luaL_addlstring(&out, s, static_cast<std::size_t>(e - s));
        return false;
    }
    if (!lua_isstring(L, -1))
        return luaL_error(L, "invalid replacement value (a %s)", luaL_typename(L, -1));
    luaL_addvalue(&out);
    return true;
}

}  // namespace

int string_find(lua_State* L) {
    return find_or_match(L, true);
}

int string_match(lua_State* L) {
    return find_or_match(L, false);
}

int string_gmatch(lua_State* L) {
    std::size_t subject_size = 0;
    std::size_t pattern_size = 0;
    const char* s = luaL_checklstring(L, 1, &subject_size);
    const char* p = luaL_checklstring(L, 2, &pattern_size);
    std::size_t init = start_position(luaL_optinteger(L, 3, 1), subject_size) - 1;
    lua_settop(L, 2);  // the closure keeps both strings alive
    auto* state = static_cast<GmatchState*>(lua_newuserdatauv(L, sizeof(GmatchState), 0));
    if (init > subject_size)
        init = subject_size + 1;  // past the end: no match, and no overflow in s + init
    new (state) GmatchState{Matcher(L, s, subject_size, p, pattern_size), s + init, p, nullptr};
    lua_pushcclosure(L, gmatch_next, 3);
    return 1;
}

int string_gsub(lua_State* L) {
    std::size_t subject_size = 0;
    std::size_t pattern_size = 0;
    const char* s = luaL_checklstring(L, 1, &subject_size);
    const char* p = luaL_checklstring(L, 2, &pattern_size);
    const int replacement_type = lua_type(L, 3);
    const lua_Integer most = luaL_optinteger(L, 4, static_cast<lua_Integer>(subject_size) + 1);
    luaL_argexpected(L,
                     replacement_type == LUA_TNUMBER || replacement_type == LUA_TSTRING ||
                         replacement_type == LUA_TFUNCTION || replacement_type == LUA_TTABLE,
                     3, "string/function/table");
    luaL_Buffer out;
    luaL_buffinit(L, &out);
    const bool anchored = pattern_size > 0 && *p == '^';
    if (anchored) {
        ++p;
        --pattern_size;
    }
    Matcher matcher(L, s, subject_size, p, pattern_size);
    const char* last_match = nullptr;
    lua_Integer count = 0;
    bool changed = false;
    while (count < most) {
        matcher.reset();
        const char* end = matcher.match(s, p);
        if (end && end != last_match) {
            ++count;
            changed = add_replacement(L, matcher, out, s, end, replacement_type) || changed;
            s = last_match = end;
        } else if (s < matcher.subject_end()) {
            luaL_addchar(&out, *s++);
        } else {
            break;
        }
        if (anchored)
            break;
    }
    if (!changed) {
        lua_pushvalue(L, 1);
    } else {
        luaL_addlstring(&out, s, static_cast<std::size_t>(matcher.subject_end() - s));
        luaL_pushresult(&out);
    }
    lua_pushinteger(L, count);
    return 2;
}

}  // namespace plexus::daemon::monitor::bounded
