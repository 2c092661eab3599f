#pragma once
// Reading the arguments of a control request's CBOR map.

#include <string>

#include <nlohmann/json.hpp>

namespace plexus::daemon {

/// The text field `key` of a request body, or "" when it is missing or not text.
inline std::string text(const nlohmann::json& body, const char* key) {
    auto it = body.find(key);
    if (it == body.end() || !it->is_string())
        return {};
    return it->get<std::string>();
}

}  // namespace plexus::daemon
