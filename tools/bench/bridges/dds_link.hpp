#pragma once
// A Link over Cyclone DDS as ROS 2 uses it: sensor_msgs/msg/Image on rt/TOPIC (the payload is the
// image's data), reliable, volatile; keep-last 10 as ROS 2's default, or keep-all for the stream.
#include <memory>
#include <string>

#include "link.hpp"

namespace plexus::bench::bridges {

/// `out` and `in` are ROS 2 topic names ("/bench/ping"); `keep_all` for the stream's flow control.
std::unique_ptr<Link> make_dds_link(const std::string& out, const std::string& in, bool keep_all);

}  // namespace plexus::bench::bridges
