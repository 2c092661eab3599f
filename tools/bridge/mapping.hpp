#pragma once
// One mapping of a bridge's command line: `FROM=TO` (mqtt) or `FROM=TO:TYPE` (ros2), checked as it
// is parsed so that a mistake is reported at start, naming the flag and what is wrong.
#include <stdexcept>
#include <string>
#include <vector>

namespace plexus::bridge {

/// A command-line or application-file mistake: the bridge says it and exits 2.
class UsageError : public std::runtime_error {
public:
    using std::runtime_error::runtime_error;
};

struct Mapping {
    std::string from;  ///< what is read: a ROS 2 topic, an MQTT topic pattern, or a Plexus port
    std::string to;    ///< where it goes: a Plexus port, a ROS 2 topic, or an MQTT topic
    std::string type;  ///< ros2 only: the message type, `pkg/msg/Name`
};

/// Parses `FROM=TO`, or `FROM=TO:TYPE` when `with_type`; `flag` ("--in") names it in errors.
/// Throws UsageError for an empty side or a missing `=` or type.
Mapping parse_mapping(const std::string& text, const std::string& flag, bool with_type);

/// Throws UsageError unless `name` is a Plexus port name (proto::port_name_error's rules).
void require_port(const std::string& name, const std::string& where);

/// Throws UsageError when two mappings open the same Plexus port (`side` picks from or to).
void require_distinct_ports(const std::vector<std::string>& ports, const std::string& where);

}  // namespace plexus::bridge
