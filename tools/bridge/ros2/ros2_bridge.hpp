#pragma once
// `plexus-bridge ros2`: ROS 2 topics to Plexus ports and back, over Cyclone DDS with ROS 2's
// conventions (topic `rt/NAME`, type `pkg::msg::dds_::Name_`, reliable volatile keep-last-10 QoS,
// ROS_DOMAIN_ID). docs/BRIDGES.md.
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "../stop_check.hpp"

namespace plexus::bridge {

struct Ros2Options {
    int domain = -1;               ///< -1: $ROS_DOMAIN_ID, else 0
    std::vector<std::string> in;   ///< ROS_TOPIC=PORT:TYPE
    std::vector<std::string> out;  ///< PORT=ROS_TOPIC:TYPE
    std::string reliability = "reliable";
    std::string durability = "volatile";
    int depth = 10;
};

CLI::App* add_ros2_command(CLI::App& app, Ros2Options& options);
/// Runs until `stop`; throws UsageError for a bad mapping or type, Error when the daemon refuses.
int run_ros2(const Ros2Options& options, const StopCheck& stop);

}  // namespace plexus::bridge
