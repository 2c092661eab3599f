#include "live_system.hpp"

#include "plexus/proto/carrier.hpp"
#include "plexus/proto/operations.hpp"
#include "replies.hpp"

namespace plexus::cli {

bool same_carrier(const std::string& wanted, const std::string& live) {
    if (wanted.empty())
        return live == "local" || live == "tcp";  // what the daemon chooses when not told
    auto a = proto::parse_carrier(wanted);
    auto b = proto::parse_carrier(live);
    if (!a || !b)
        return wanted == live;
    return a->text() == b->text();  // canonical texts: "tcp+recv.priority+tc.0.5" however written
}

LiveSystem::LiveSystem(const std::string& socket) : client_(Client::Options{socket}) {}

std::string LiveSystem::node() {
    return read_as<proto::NodeReply>(client_.request(proto::NodeRequest{}.encode())).node;
}

bool LiveSystem::port_exists(const std::string& port) {
    return client_.lookup(port).has_value();
}

std::vector<LiveConnection> LiveSystem::connections() {
    std::vector<LiveConnection> out;
    for (const auto& c : client_.list().value("connections", Value::array())) {
        out.push_back({c.value("source", ""), c.value("destination", ""), c.value("carrier", ""),
                       c.value("persistent", false), c.value("live", false)});
    }
    return out;
}

std::optional<LiveConnection> LiveSystem::find(const std::vector<LiveConnection>& all,
                                               const std::string& source, const std::string& destination) {
    for (const auto& c : all) {
        if (c.source == source && c.destination == destination)
            return c;
    }
    return std::nullopt;
}

std::vector<std::string> LiveSystem::connect(const std::string& source, const std::string& destination,
                                             const std::string& carrier, bool persist) {
    proto::ConnectRequest asked;
    asked.source = source;
    asked.destination = destination;
    asked.carrier = carrier;
    asked.persist = persist;
    return read_as<proto::ConnectReply>(client_.request(asked.encode())).warnings;
}

void LiveSystem::disconnect(const std::string& source, const std::string& destination) {
    client_.disconnect(source, destination);
}

}  // namespace plexus::cli
