#pragma once
// Converting message payloads between nlohmann::json (what CBOR decodes to) and Lua values.
// Maps become tables, arrays sequences, binary blobs strings. Going back, a Lua string becomes a
// binary blob where the original value had one (the "hint"), else text when it is valid UTF-8.

#include <cstdint>
#include <span>
#include <string>

#include <lua.hpp>
#include <nlohmann/json.hpp>

namespace plexus::daemon::monitor {

/// Pushes `value` onto the Lua stack. Raises a Lua error (memory) like any Lua API call.
void push_json(lua_State* L, const nlohmann::json& value);

/// Pushes the CBOR value that fills `bytes` straight into Lua values, without building json
/// first (the per-message path of msg.data). Raises a Lua error for malformed CBOR. Indefinite
/// lengths, which nlohmann's encoder never writes, take the slower path through json.
void push_cbor(lua_State* L, std::span<const std::uint8_t> bytes);

/// Converts the Lua value at `index`. `hint`, when given, is the value it was decoded from: it
/// keeps blobs blobs and empty tables arrays. Raises a Lua error for functions, userdata, cycles
/// and nesting deeper than 64.
nlohmann::json to_json(lua_State* L, int index, const nlohmann::json* hint = nullptr);

}  // namespace plexus::daemon::monitor
