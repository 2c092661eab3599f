// Payloads into Lua values and back (daemon/monitor/lua_value.hpp), on arbitrary CBOR.
// Properties, for what decode_cbor_fast accepts:
//   - json -> Lua -> json with the value as its hint gives the value back, within what the
//     conversion promises (lua_value.hpp): a Lua table cannot hold nil, so members that are null
//     disappear and arrays holding null are not compared; a binary subtype is not kept; an unsigned
//     integer above Lua's largest integer comes back as a float; a string that is not UTF-8 comes
//     back as a binary blob;
//   - push_cbor (the fast path a monitor's msg.data takes) and push_json of the decoded value give
//     Lua values that convert back to the same json;
//   - a map read lazily (monitor/lazy_map.hpp, msg.data of a map) gives, field by field, the values
//     of the table push_cbor builds, and once made whole holds the same keys and values.
// Lua errors (nesting deeper than the conversion allows, a NaN map key) are allowed answers:
// everything runs inside lua_pcall, as in the monitors.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <optional>
#include <string_view>

#include <lua.hpp>
#include <nlohmann/json.hpp>

#include "fuzz_check.hpp"
#include "monitor/lazy_map.hpp"
#include "monitor/lua_value.hpp"
#include "plexus/proto/cbor.hpp"
#include "same_json.hpp"

namespace monitor = plexus::daemon::monitor;
namespace proto = plexus::proto;
using nlohmann::json;

namespace {

bool valid_utf8(std::string_view text) {
    try {
        (void)json(std::string(text)).dump();  // dump() refuses invalid UTF-8 by throwing
        return true;
    } catch (const json::exception&) {
        return false;
    }
}

/// What `value` should come back as after a trip through Lua; nullopt when the conversion
/// promises nothing (an array holding null: a Lua sequence cannot have holes).
std::optional<json> expected_back(const json& value) {
    switch (value.type()) {
        case json::value_t::number_unsigned: {
            const auto u = value.get<std::uint64_t>();
            if (u > static_cast<std::uint64_t>(LUA_MAXINTEGER))
                return json(static_cast<double>(u));
            return value;
        }
        case json::value_t::string:
            if (!valid_utf8(value.get_ref<const std::string&>())) {
                const auto& s = value.get_ref<const std::string&>();
                return json::binary(std::vector<std::uint8_t>(s.begin(), s.end()));
            }
            return value;
        case json::value_t::binary:
            return json::binary(std::vector<std::uint8_t>(value.get_binary()));
        case json::value_t::array: {
            auto out = json::array();
            for (const auto& element : value) {
                if (element.is_null())
                    return std::nullopt;
                auto back = expected_back(element);
                if (!back)
                    return std::nullopt;
                out.push_back(std::move(*back));
            }
            return out;
        }
        case json::value_t::object: {
            auto out = json::object();
            for (const auto& [key, element] : value.items()) {
                if (element.is_null())
                    continue;
                auto back = expected_back(element);
                if (!back)
                    return std::nullopt;
                out[key] = std::move(*back);
            }
            return out;
        }
        default:
            return value;
    }
}

struct Trip {
    proto::ByteView bytes;
    const json* value = nullptr;
    std::optional<json> through_json;  ///< push_json, then to_json
    std::optional<json> through_cbor;  ///< push_cbor, then to_json
    bool lazy_fields_differ = false;
};

/// The two conversions, each in its own protected call so that a Lua error in one leaves the other.
int via_json(lua_State* L) {
    auto* trip = static_cast<Trip*>(lua_touserdata(L, 1));
    monitor::push_json(L, *trip->value);
    trip->through_json = monitor::to_json(L, -1, trip->value);
    return 0;
}

int via_cbor(lua_State* L) {
    auto* trip = static_cast<Trip*>(lua_touserdata(L, 1));
    monitor::push_cbor(L, trip->bytes);
    trip->through_cbor = monitor::to_json(L, -1, trip->value);
    return 0;
}

/// Whether the values at the top two slots are the same (tables: through json; NaN is NaN).
bool same_value(lua_State* L) {
    if (lua_type(L, -1) == LUA_TTABLE || lua_type(L, -2) == LUA_TTABLE)
        return lua_type(L, -1) == lua_type(L, -2) &&
               plexus::fuzz::same_json(monitor::to_json(L, -1), monitor::to_json(L, -2));
    if (lua_type(L, -1) == LUA_TNUMBER && lua_type(L, -2) == LUA_TNUMBER && !lua_isinteger(L, -1) &&
        !lua_isinteger(L, -2) && std::isnan(lua_tonumber(L, -1)) && std::isnan(lua_tonumber(L, -2)))
        return true;
    return lua_rawequal(L, -1, -2) != 0;
}

int via_lazy(lua_State* L) {
    auto* trip = static_cast<Trip*>(lua_touserdata(L, 1));
    monitor::push_cbor(L, trip->bytes);  // raises for malformed bytes: then nothing to compare
    const int eager = lua_gettop(L);
    monitor::LazyMaps maps;
    maps.install(L);
    if (!lua_istable(L, eager) || !maps.push(L, trip->bytes))
        return 0;
    const int lazy = lua_gettop(L);
    lua_pushnil(L);
    while (lua_next(L, eager) != 0) {
        if (lua_type(L, -2) == LUA_TTABLE) {  // a map or array as a key: a different table in each
            lua_pop(L, 1);                    // decoding, found by identity only; no script can name it
            continue;
        }
        lua_pushvalue(L, -2);
        lua_gettable(L, lazy);  // the lazy read (or, once materialized, the plain one)
        if (!same_value(L))
            trip->lazy_fields_differ = true;
        lua_pop(L, 2);
    }
    // Then the whole table, as pairs makes it: the same keys with the same values (compared in
    // Lua, not as json: to_json of a table holding both "-10" and -10 keeps whichever comes last).
    monitor::materialize_if_lazy(L, lazy);
    std::size_t eager_keys = 0;
    std::size_t lazy_keys = 0;
    lua_pushnil(L);
    while (lua_next(L, eager) != 0) {
        ++eager_keys;
        lua_pop(L, 1);
    }
    lua_pushnil(L);
    while (lua_next(L, lazy) != 0) {
        ++lazy_keys;
        if (lua_type(L, -2) != LUA_TTABLE) {
            lua_pushvalue(L, -2);
            lua_rawget(L, eager);
            if (!same_value(L))
                trip->lazy_fields_differ = true;
            lua_pop(L, 1);
        }
        lua_pop(L, 1);
    }
    if (eager_keys != lazy_keys)
        trip->lazy_fields_differ = true;
    (void)monitor::to_json(L, lazy, trip->value);  // converting a table made lazily: no crash
    maps.end_message();
    return 0;
}

void protected_call(lua_State* L, lua_CFunction function, Trip& trip) {
    lua_pushcfunction(L, function);
    lua_pushlightuserdata(L, &trip);
    if (lua_pcall(L, 1, 0, 0) != LUA_OK)
        lua_pop(L, 1);  // the error message
    lua_settop(L, 0);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    // A fresh state per run: nothing carries over from one input to the next (a crash reproduces
    // from its input alone), and every allocation is freed within the run, which spares libFuzzer
    // the leak scan it does after any run whose mallocs and frees do not balance (90% of the time).
    lua_State* L = luaL_newstate();
    const proto::ByteView bytes(data, size);
    const auto decoded = proto::decode_cbor_fast(bytes);
    Trip trip;
    trip.bytes = bytes;
    trip.value = decoded ? &*decoded : nullptr;
    if (decoded)
        protected_call(L, via_json, trip);
    // push_cbor takes any bytes: malformed ones must give a Lua error, not a crash.
    protected_call(L, via_cbor, trip);
    protected_call(L, via_lazy, trip);
    lua_close(L);
    // The lazy reads hold for any map push_cbor takes (integer keys too, which json has not).
    PLEXUS_FUZZ_CHECK(!trip.lazy_fields_differ);
    if (!decoded)
        return 0;
    if (trip.through_json) {
        if (const auto expected = expected_back(*decoded))
            PLEXUS_FUZZ_CHECK(plexus::fuzz::same_json(*trip.through_json, *expected));
    }
    if (trip.through_json && trip.through_cbor)
        PLEXUS_FUZZ_CHECK(plexus::fuzz::same_json(*trip.through_json, *trip.through_cbor));
    return 0;
}
