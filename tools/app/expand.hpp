#pragma once
// Variables in application files: `${NAME}` and `${NAME:-default}` take their value from the
// environment of the `plexus` command that reads the file, so that one file serves several
// set-ups (a speed, a seed, the node a component runs on). `$$` is a literal `$`.

#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "plexus/proto/bytes.hpp"

namespace plexus::app {

/// A variable's value, or none when it is not set.
using VariableLookup = std::function<std::optional<std::string>(const std::string&)>;

/// The process environment, as a VariableLookup.
VariableLookup process_environment();

/// Replaces every `${NAME}` and `${NAME:-default}` (the default also when NAME is set but empty,
/// as in the shell). Errors: an unset variable without a default, a `${` without its `}`, a name
/// that is not [A-Za-z_][A-Za-z0-9_]*.
proto::Result<std::string> expand_variables(std::string_view text, const VariableLookup& lookup);

}  // namespace plexus::app
