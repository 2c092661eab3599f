#pragma once
// msg.data of a map payload, decoded a field at a time (docs/MONITORS.md, "msg.data").
//
// A one-field `accept` reads one value of the map: decoding the whole payload into a table (its
// strings, its nested maps) costs more than the script. So when the payload is a CBOR map,
// msg.data is an empty table with a metatable: reading a field scans the CBOR for that key and
// decodes only its value. Anything else turns it into the plain table an eager decoder would
// have built ("materializes" it): a write, `pairs`, `#`, the raw functions, `getmetatable`,
// `setmetatable`, reading a field whose value is a map or an array (the script may change that
// table in place), converting it back to a payload (publish, update), or many reads.
//
// The bytes belong to the message: a table still lazy when the message's callbacks are over
// cannot read any more, and says so (keep a copy, or materialize it with `pairs`, to keep data).

#include <cstddef>
#include <cstdint>
#include <span>

#include <lua.hpp>

namespace plexus::daemon::monitor {

/// The lazily decoded msg.data of one Lua state (one monitor): one lazy table at a time.
class LazyMaps {
public:
    /// Makes the tables' metatable and wraps the raw functions of the state's globals (next,
    /// rawget, rawset, rawlen, getmetatable, setmetatable) so that they materialize first. In a
    /// protected call: raises for memory. `this` must outlive the state's use of msg.data.
    void install(lua_State* L);

    /// Pushes a lazy table over `payload` when it is a CBOR map (of definite length); false,
    /// nothing pushed, otherwise. `payload` must stay valid until end_message().
    bool push(lua_State* L, std::span<const std::uint8_t> payload);

    /// Whether the table pushed last is still lazy: never written, never materialized.
    bool pending() const { return current_ != nullptr; }

    /// The message's callbacks are over: its table, if still lazy, reads no more.
    void end_message() { current_ = nullptr; }

private:
    static int index(lua_State* L);
    static int new_index(lua_State* L);
    static int length(lua_State* L);
    static int pairs(lua_State* L);
    static int materialize_method(lua_State* L);
    static int raw_wrapper(lua_State* L);

    /// Turns the lazy table at `index` into a plain table; raises if it is not the current one.
    void materialize(lua_State* L, int index);
    /// Materializes table 1 and answers the read of key 2 from the plain table.
    int read_plain(lua_State* L);
    /// Raises unless the table at `index` is the current lazy table.
    void check_current(lua_State* L, int index) const;

    const void* current_ = nullptr;  ///< lua_topointer of the current lazy table
    std::span<const std::uint8_t> payload_;
    int reads_ = 0;  ///< scans of the current table: past a few, materializing is cheaper
    int metatable_ref_ = LUA_NOREF;
};

/// Materializes the table at `index` if it is a lazy msg.data (raises if that one is stale);
/// anything else is left alone. For code that reads tables raw (to_json).
void materialize_if_lazy(lua_State* L, int index);

}  // namespace plexus::daemon::monitor
