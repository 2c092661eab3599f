#include "mqtt_bridge.hpp"

#include "mapping.hpp"

namespace plexus::bridge {

CLI::App* add_mqtt_command(CLI::App& app, MqttOptions& options) {
    auto* command = app.add_subcommand("mqtt", "MQTT topics to Plexus ports and back (libmosquitto)");
    command->add_option("--broker", options.broker, "the broker, HOST:PORT")->capture_default_str();
    command->add_option("--in", options.in, "'TOPIC_PATTERN=PORT': MQTT messages into a Plexus port");
    command->add_option("--out", options.out, "'PORT=TOPIC': a Plexus port's messages out to MQTT");
    return command;
}

int run_mqtt(const MqttOptions&, const StopCheck&) {
    throw UsageError("mqtt: not built yet");
}

}  // namespace plexus::bridge
