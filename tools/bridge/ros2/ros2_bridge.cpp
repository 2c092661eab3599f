#include "ros2_bridge.hpp"

#include "mapping.hpp"

namespace plexus::bridge {

CLI::App* add_ros2_command(CLI::App& app, Ros2Options& options) {
    auto* command = app.add_subcommand("ros2", "ROS 2 topics to Plexus ports and back (Cyclone DDS)");
    command->add_option("--domain", options.domain, "the ROS 2 domain id (default: $ROS_DOMAIN_ID, else 0)");
    command->add_option("--in", options.in, "ROS_TOPIC=PORT:TYPE: a ROS 2 topic into a Plexus port");
    command->add_option("--out", options.out, "PORT=ROS_TOPIC:TYPE: a Plexus port out to a ROS 2 topic");
    return command;
}

int run_ros2(const Ros2Options&, const StopCheck&) {
    throw UsageError("ros2: not built yet");
}

}  // namespace plexus::bridge
