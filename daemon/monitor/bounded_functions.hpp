#pragma once
// Threading: whichever thread runs the Lua state that calls them.
//
// Our own versions of the standard-library functions whose stock versions can run unbounded in C
// (no Lua instruction, so the budget hook never fires). Each charges its work to the sandbox's
// time budget (LuaSandbox::charge) and keeps Lua 5.4's semantics; docs/MONITORS.md lists them.
// bounded_library.cpp puts them in place of the stock ones.

#include <lua.hpp>

namespace plexus::daemon::monitor::bounded {

// lua_pattern.cpp: the pattern functions, on a matcher of our own.
int string_find(lua_State* L);
int string_match(lua_State* L);
int string_gmatch(lua_State* L);
int string_gsub(lua_State* L);

// bounded_string.cpp
int string_rep(lua_State* L);
/// string.format: the stock function, fed a bounded piece of the format at a time. Upvalue 1 is it.
int string_format(lua_State* L);
/// string.pack with a bounded format (length and "cN" sizes); upvalue 1 is the stock function.
int string_pack(lua_State* L);
/// string.unpack and string.packsize with a bounded format length; upvalue 1 is the stock one.
int string_unpack_or_packsize(lua_State* L);

// bounded_load.cpp
/// Replaces load's chunk (argument 1, a string or a reader function) with a reader that hands it
/// to the compiler in pieces, charging each; leaves other arguments as they were.
void replace_chunk_with_reader(lua_State* L);

// bounded_table.cpp
int table_insert(lua_State* L);
int table_remove(lua_State* L);
int table_move(lua_State* L);
int table_concat(lua_State* L);
int table_unpack(lua_State* L);
int table_sort(lua_State* L);

// bounded_utf8.cpp
int utf8_len(lua_State* L);
int utf8_offset(lua_State* L);
int utf8_codepoint(lua_State* L);
int utf8_codes(lua_State* L);

}  // namespace plexus::daemon::monitor::bounded
