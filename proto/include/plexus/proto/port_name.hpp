#pragma once
// Port names: start with '/', no spaces, no "//", no trailing '/', at most 255 bytes of
// [A-Za-z0-9_./:-].

#include <optional>
#include <string>
#include <string_view>

namespace plexus::proto {

/// Empty when the name is valid; otherwise the broken rule, e.g.
/// "port name \"a/b\" must start with '/'".
std::optional<std::string> port_name_error(std::string_view name);

inline bool is_valid_port_name(std::string_view name) {
    return !port_name_error(name);
}

}  // namespace plexus::proto
