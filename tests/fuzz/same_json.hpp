#pragma once
// Equality of decoded values for round-trip properties: nlohmann's == says NaN != NaN, but a NaN
// that went out and came back is the same value for us. Binary subtypes count, as in ==.

#include <cmath>

#include <nlohmann/json.hpp>

namespace plexus::fuzz {

inline bool same_json(const nlohmann::json& a, const nlohmann::json& b) {
    if (a.is_number_float() && b.is_number_float() && std::isnan(a.get<double>()) &&
        std::isnan(b.get<double>()))
        return true;
    if (a.type() != b.type())
        return a == b;  // integer and unsigned of one value are equal; anything else is not
    if (a.is_array()) {
        if (a.size() != b.size())
            return false;
        for (std::size_t i = 0; i < a.size(); ++i) {
            if (!same_json(a[i], b[i]))
                return false;
        }
        return true;
    }
    if (a.is_object()) {
        if (a.size() != b.size())
            return false;
        for (auto it = a.begin(), other = b.begin(); it != a.end(); ++it, ++other) {
            if (it.key() != other.key() || !same_json(it.value(), other.value()))
                return false;
        }
        return true;
    }
    return a == b;
}

}  // namespace plexus::fuzz
