#pragma once
// Reading an application file for a command: schema, variables and every check; what is wrong
// goes to stderr, one line per problem.

#include <optional>
#include <string>

#include "app_file.hpp"

namespace plexus::cli {

/// The application, or none after printing every problem (the caller exits 2). Warnings are
/// printed too. `full_check` false reads the schema only (down works with what it can read).
std::optional<app::App> load_checked_app(const std::string& file, bool full_check = true);

/// "1 connection", "3 connections".
inline std::string counted(std::size_t n, const std::string& noun) {
    return std::to_string(n) + " " + noun + (n == 1 ? "" : "s");
}

}  // namespace plexus::cli
