#pragma once
// Threading: none of its own; a builder belongs to one monitor, used by one thread at a time.
//
// The values of the plugin ABI (plexus/monitor_plugin.h): reading a CBOR value in place, through a
// plexus_value view, and building one with a plexus_builder. The daemon's payloads are CBOR, so a
// plugin reads the message's bytes where they are: no decoding into a tree, no allocation. Every
// read is bounds-checked against the view, since a payload is whatever a client sent.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "plexus/monitor_plugin.h"

/// A value being built: CBOR bytes and the count of items each open array or map still expects.
struct plexus_builder {
    std::vector<unsigned char> bytes;
    std::vector<std::uint64_t> open;
    bool complete = false;  ///< one whole top-level value is there
    std::string misuse;     ///< the first wrong call (empty if none): the value is then unusable
};

namespace plexus::daemon::monitor::plugin_values {

/// Deepest nesting read or built: a payload is data, not a recursion attack.
inline constexpr std::size_t max_depth = 64;

plexus_type type(plexus_value value);
int get_bool(plexus_value value, int* out);
int get_int(plexus_value value, std::int64_t* out);
int get_number(plexus_value value, double* out);
int get_string(plexus_value value, const char** data, std::size_t* size);
int get_bytes(plexus_value value, const unsigned char** data, std::size_t* size);
std::size_t length(plexus_value value);
plexus_value array_at(plexus_value array, std::size_t index);
plexus_value map_get(plexus_value map, const char* key);
int map_entry(plexus_value map, std::size_t index, plexus_value* key, plexus_value* value);
/// The view of the first whole item in `value` (a payload may be followed by nothing else, but a
/// view built by hand could be longer); absent if malformed.
plexus_value first_item(plexus_value value);

void reset(plexus_builder* builder);
/// The finished value, or absent.
plexus_value value_of(plexus_builder* builder);
/// Why value_of is absent: "" when the value is complete.
std::string problem_of(const plexus_builder& builder);
void put_null(plexus_builder* builder);
void put_bool(plexus_builder* builder, int value);
void put_int(plexus_builder* builder, std::int64_t value);
void put_float(plexus_builder* builder, double value);
void put_string(plexus_builder* builder, const char* data, std::size_t size);
void put_bytes(plexus_builder* builder, const void* data, std::size_t size);
void begin_array(plexus_builder* builder, std::size_t count);
void begin_map(plexus_builder* builder, std::size_t count);
void put_value(plexus_builder* builder, plexus_value value);

}  // namespace plexus::daemon::monitor::plugin_values
