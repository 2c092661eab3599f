#pragma once
// The name server's operations and the records they carry: one header for the server that answers
// them and the daemon's client that asks, so an op name is spelled in one place.

#include <string>

namespace plexus::daemon::names {

/// Op names of the name server's requests (PROTOCOL.md, "Control operations").
namespace op {
inline constexpr const char* ping = "ping";
inline constexpr const char* lookup = "lookup";
inline constexpr const char* list = "list";
inline constexpr const char* register_node = "register_node";
inline constexpr const char* register_port = "register_port";
inline constexpr const char* unregister_port = "unregister_port";
inline constexpr const char* add_connection = "add_connection";
inline constexpr const char* remove_connection = "remove_connection";
inline constexpr const char* mcast_group = "mcast_group";  ///< the multicast group of a source port
inline constexpr const char* discover = "discover";        ///< multicast only: where is the name server
}  // namespace op

struct PortEntry {
    std::string name;
    std::string node;
    std::string address;  ///< the node daemon's TCP address, HOST:PORT
};

struct ConnectionEntry {
    std::string source;
    std::string destination;
    std::string carrier;
    bool persistent = false;
};

}  // namespace plexus::daemon::names
