// plexus-bridge: a component that maps another system's topics to Plexus ports and back, so that
// Plexus's monitors and arbitration can coordinate programs that were never written for it
// (docs/BRIDGES.md).
//
//     plexus-bridge ros2 --in /chatter=/ros/chatter:std_msgs/msg/String --out
//     /robot/cmd_vel=/cmd_vel:geometry_msgs/msg/Twist plexus-bridge mqtt --broker localhost:1883 --in
//     'sensors/+/temp=/mqtt/temp' --out '/robot/state=robot/state'
//
// Exit codes as the CLI's: 0 stopped by SIGINT/SIGTERM, 2 a usage mistake (an unknown type, a
// malformed mapping), 4 the daemon or the other system refused.
#include <iostream>

#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>

#include "mapping.hpp"
#include "mqtt_bridge.hpp"
#include "plexus/client.hpp"
#include "ros2_bridge.hpp"
#include "stop_signal.hpp"

int main(int argc, char** argv) {
    CLI::App app{
        "plexus-bridge: maps ROS 2 topics (over Cyclone DDS) or MQTT topics to Plexus ports and "
        "back. Messages it cannot convert or deliver are counted on its ports (plexus stats PORT, "
        "\"reported\") and each reason is logged once. docs/BRIDGES.md explains."};
    app.require_subcommand(1);
    std::string log_level = "info";
    app.add_option("--log-level", log_level, "trace, debug, info, warn, error")->capture_default_str();
    plexus::bridge::Ros2Options ros2;
    auto* ros2_command = plexus::bridge::add_ros2_command(app, ros2);
    plexus::bridge::MqttOptions mqtt;
    auto* mqtt_command = plexus::bridge::add_mqtt_command(app, mqtt);
    CLI11_PARSE(app, argc, argv);
    spdlog::set_level(spdlog::level::from_str(log_level));

    plexus::sim::install_stop_handlers();
    const auto stop = [] { return plexus::sim::stop_requested(); };
    try {
        if (ros2_command->parsed())
            return plexus::bridge::run_ros2(ros2, stop);
        if (mqtt_command->parsed())
            return plexus::bridge::run_mqtt(mqtt, stop);
    } catch (const plexus::bridge::UsageError& e) {
        std::cerr << "plexus-bridge: " << e.what() << '\n';
        return static_cast<int>(plexus::ErrorCode::usage);
    } catch (const plexus::Error& e) {
        std::cerr << "plexus-bridge: " << e.what() << '\n';
        return static_cast<int>(e.code());
    }
    return 0;
}
