#pragma once
// plexusd's JSON config file (--config): read apart from main() so that unit tests and the fuzzer
// (tests/fuzz/) reach the parsing without starting a daemon.

#include <string>
#include <string_view>

#include "daemon_config.hpp"

namespace plexus::daemon {

/// Applies the config file at `path` to `config`; command-line flags given explicitly win over it
/// (they are applied after). Throws std::runtime_error, or nlohmann::json's exceptions (all
/// std::exception), saying what is wrong: an unknown key, a value out of range, bad JSON.
void apply_config_file(const std::string& path, DaemonConfig& config);

/// The same for the file's `text`; `path` only names the file in messages.
void apply_config_text(const std::string& path, std::string_view text, DaemonConfig& config);

}  // namespace plexus::daemon
