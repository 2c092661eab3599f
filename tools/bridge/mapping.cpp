#include "mapping.hpp"

#include <set>

#include "plexus/proto/port_name.hpp"

namespace plexus::bridge {

Mapping parse_mapping(const std::string& text, const std::string& flag, bool with_type) {
    const std::string form = with_type ? "FROM=TO:TYPE" : "FROM=TO";
    const auto equals = text.find('=');
    if (equals == std::string::npos)
        throw UsageError(flag + " '" + text + "': expected " + form);
    Mapping mapping;
    mapping.from = text.substr(0, equals);
    mapping.to = text.substr(equals + 1);
    if (with_type) {
        // Port names and ROS 2 topics have no ':', so the type starts after the last one.
        const auto colon = mapping.to.rfind(':');
        if (colon == std::string::npos)
            throw UsageError(flag + " '" + text + "': expected " + form + " (the type is missing, e.g. " +
                             ":std_msgs/msg/String)");
        mapping.type = mapping.to.substr(colon + 1);
        mapping.to.resize(colon);
        if (mapping.type.empty())
            throw UsageError(flag + " '" + text + "': the type after ':' is empty");
    }
    if (mapping.from.empty() || mapping.to.empty())
        throw UsageError(flag + " '" + text + "': expected " + form + " with both sides named");
    return mapping;
}

void require_port(const std::string& name, const std::string& where) {
    if (const auto error = proto::port_name_error(name))
        throw UsageError(where + ": '" + name + "' is not a port name: " + *error);
}

void require_distinct_ports(const std::vector<std::string>& ports, const std::string& where) {
    std::set<std::string> seen;
    for (const auto& port : ports) {
        if (!seen.insert(port).second)
            throw UsageError(where + ": port " + port + " is mapped twice");
    }
}

}  // namespace plexus::bridge
