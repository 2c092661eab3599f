#pragma once
// For the tests' checks of error messages and logs (std::string::contains is C++23).

#include <string>

inline bool contains(const std::string& text, const std::string& part) {
    return text.find(part) != std::string::npos;
}
