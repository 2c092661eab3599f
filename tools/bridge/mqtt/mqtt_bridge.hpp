#pragma once
// `plexus-bridge mqtt`: MQTT topics (patterns with + and #) to Plexus ports and back, over Debian's
// libmosquitto. docs/BRIDGES.md (the MQTT part).
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "../stop_check.hpp"

namespace plexus::bridge {

/// The command line of `plexus-bridge mqtt`; the TLS and login flags are mosquitto_sub's.
struct MqttOptions {
    std::string broker = "localhost:1883";  ///< HOST:PORT
    std::vector<std::string> in;            ///< 'TOPIC_PATTERN=PORT'
    std::vector<std::string> out;           ///< 'PORT=TOPIC'
    int qos = 1;                            ///< 0 or 1, for subscriptions and publications
    bool retain = false;                    ///< publish retained on --out topics
    std::string payload = "json";           ///< json or raw
    bool envelope = false;                  ///< inbound values {"topic","payload","retained"}
    std::string id;                         ///< MQTT client id; empty: a random one
    std::optional<std::string> username;
    std::optional<std::string> password;  ///< else $MQTT_PASSWORD
    std::string cafile;
    std::string capath;
    std::string cert;
    std::string key;
    bool insecure = false;
    int keepalive = 60;
    std::size_t held = 1000;  ///< publications held while the broker is away
};

CLI::App* add_mqtt_command(CLI::App& app, MqttOptions& options);
/// Runs until `stop`; throws UsageError for a bad mapping, Error when the daemon refuses.
int run_mqtt(const MqttOptions& options, const StopCheck& stop);

}  // namespace plexus::bridge
