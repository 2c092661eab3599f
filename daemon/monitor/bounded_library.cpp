#include "bounded_library.hpp"

#include "bounded_functions.hpp"
#include "lua_sandbox.hpp"

namespace plexus::daemon::monitor {

namespace {

/// A stock function whose work is linear in its argument count (up to Lua's stack limit of a
/// million values, a few milliseconds): charged by that count, then run in the same call frame.
int charged_by_arguments(lua_State* L) {
    LuaSandbox::charge(L, lua_gettop(L));
    return lua_tocfunction(L, lua_upvalueindex(1))(L);
}

void replace(lua_State* L, const char* field, lua_CFunction bounded) {
    lua_pushcfunction(L, bounded);
    lua_setfield(L, -2, field);
}

/// Wraps library[field] (the table at the top) in a closure of `wrapper` with it as upvalue 1.
void wrap(lua_State* L, const char* field, lua_CFunction wrapper) {
    lua_getfield(L, -1, field);
    lua_pushcclosure(L, wrapper, 1);
    lua_setfield(L, -2, field);
}

}  // namespace

void open_bounded_library(lua_State* L) {
    lua_getglobal(L, LUA_STRLIBNAME);
    replace(L, "find", bounded::string_find);
    replace(L, "match", bounded::string_match);
    replace(L, "gmatch", bounded::string_gmatch);
    replace(L, "gsub", bounded::string_gsub);
    replace(L, "rep", bounded::string_rep);
    wrap(L, "format", bounded::string_format);
    wrap(L, "char", charged_by_arguments);
    wrap(L, "pack", bounded::string_pack);
    wrap(L, "unpack", bounded::string_unpack_or_packsize);
    wrap(L, "packsize", bounded::string_unpack_or_packsize);
    lua_pop(L, 1);

    lua_getglobal(L, LUA_TABLIBNAME);
    replace(L, "insert", bounded::table_insert);
    replace(L, "remove", bounded::table_remove);
    replace(L, "move", bounded::table_move);
    replace(L, "concat", bounded::table_concat);
    replace(L, "unpack", bounded::table_unpack);
    replace(L, "sort", bounded::table_sort);
    wrap(L, "pack", charged_by_arguments);
    lua_pop(L, 1);

    lua_getglobal(L, LUA_UTF8LIBNAME);
    replace(L, "len", bounded::utf8_len);
    replace(L, "offset", bounded::utf8_offset);
    replace(L, "codepoint", bounded::utf8_codepoint);
    replace(L, "codes", bounded::utf8_codes);
    wrap(L, "char", charged_by_arguments);
    lua_pop(L, 1);

    lua_getglobal(L, LUA_MATHLIBNAME);
    wrap(L, "max", charged_by_arguments);
    wrap(L, "min", charged_by_arguments);
    lua_pop(L, 1);

    lua_pushglobaltable(L);
    wrap(L, "select", charged_by_arguments);
    lua_pop(L, 1);
}

}  // namespace plexus::daemon::monitor
