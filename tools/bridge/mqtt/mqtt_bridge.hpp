#pragma once
// `plexus-bridge mqtt`: MQTT topics (patterns with + and #) to Plexus ports and back, over Debian's
// libmosquitto. docs/BRIDGES.md.
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "../stop_check.hpp"

namespace plexus::bridge {

struct MqttOptions {
    std::string broker = "localhost:1883";  ///< HOST:PORT
    std::vector<std::string> in;             ///< 'TOPIC_PATTERN=PORT'
    std::vector<std::string> out;            ///< 'PORT=TOPIC'
};

CLI::App* add_mqtt_command(CLI::App& app, MqttOptions& options);
/// Runs until `stop`; throws UsageError for a bad mapping, Error when the daemon refuses.
int run_mqtt(const MqttOptions& options, const StopCheck& stop);

}  // namespace plexus::bridge
