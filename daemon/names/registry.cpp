#include "registry.hpp"

#include <algorithm>

#include "plexus/proto/carrier.hpp"
#include "plexus/proto/port_name.hpp"

namespace plexus::daemon::names {

proto::Status Registry::register_node(const std::string& node, const std::string& address,
                                      std::uint64_t session) {
    if (node.empty())
        return proto::Error{"node name is empty"};
    if (node.size() > max_node_text || address.size() > max_node_text)
        return proto::Error{"node name or address longer than " + std::to_string(max_node_text) + " bytes"};
    auto it = nodes_.find(node);
    if (it == nodes_.end() && nodes_.size() >= max_nodes)
        return proto::Error{"the name server already knows " + std::to_string(max_nodes) + " nodes"};
    if (it != nodes_.end() && it->second.session != 0 && it->second.session != session) {
        return proto::Error{"node '" + node + "' is already registered by a running daemon at " +
                            it->second.address + "; give this daemon another --node name"};
    }
    if (it != nodes_.end() && it->second.address != address) {
        // Same node name, new address: the daemon restarted; its old ports are stale.
        std::vector<std::string> removed;
        remove_ports_of(node, removed);
    }
    nodes_[node] = Node{address, session, {}};
    return proto::Ok{};
}

const Registry::Node* Registry::node_of_session(std::uint64_t session, std::string* name) const {
    for (const auto& [node_name, node] : nodes_) {
        if (node.session == session && session != 0) {
            if (name)
                *name = node_name;
            return &node;
        }
    }
    return nullptr;
}

proto::Status Registry::register_port(const std::string& name, std::uint64_t session) {
    if (auto error = proto::port_name_error(name))
        return proto::Error{*error};
    std::string node_name;
    const Node* node = node_of_session(session, &node_name);
    if (!node)
        return proto::Error{"register the node before its ports"};
    auto it = ports_.find(name);
    if (it != ports_.end() && it->second.node != node_name) {
        return proto::Error{"port " + name + " already exists on node '" + it->second.node + "'"};
    }
    if (it == ports_.end() && ports_.size() >= max_ports)
        return proto::Error{"the name server already knows " + std::to_string(max_ports) + " ports"};
    ports_[name] = PortEntry{name, node_name, node->address};
    return proto::Ok{};
}

proto::Status Registry::unregister_port(const std::string& name, std::uint64_t session) {
    std::string node_name;
    if (!node_of_session(session, &node_name))
        return proto::Error{"register the node before its ports"};
    auto it = ports_.find(name);
    if (it == ports_.end())
        return proto::Error{"port " + name + " is not registered"};
    if (it->second.node != node_name)
        return proto::Error{"port " + name + " belongs to node '" + it->second.node + "'"};
    ports_.erase(it);
    release_mcast_group(name);
    std::erase_if(connections_, [&](const ConnectionEntry& c) {
        return !c.persistent && (c.source == name || c.destination == name);
    });
    return proto::Ok{};
}

std::optional<PortEntry> Registry::lookup(const std::string& name) const {
    auto it = ports_.find(name);
    if (it == ports_.end())
        return std::nullopt;
    return it->second;
}

proto::Status Registry::owns_source(const std::string& source, std::uint64_t session) const {
    std::string node_name;
    if (!node_of_session(session, &node_name))
        return proto::Error{"register the node before its connections"};
    // A connection is made and unmade by the daemon of its source: only that node may change it.
    const auto it = ports_.find(source);
    if (it == ports_.end())
        return proto::Error{"port " + source + " is not registered"};
    if (it->second.node != node_name)
        return proto::Error{"port " + source + " belongs to node '" + it->second.node + "', not '" +
                            node_name + "'"};
    return proto::Ok{};
}

proto::Status Registry::add_connection(ConnectionEntry entry, std::uint64_t session) {
    for (const auto* name : {&entry.source, &entry.destination}) {
        if (auto error = proto::port_name_error(*name))
            return proto::Error{*error};
    }
    if (auto owned = owns_source(entry.source, session); !owned)
        return owned;
    if (entry.carrier.size() > max_carrier_text)
        return proto::Error{"carrier longer than " + std::to_string(max_carrier_text) + " bytes"};
    for (auto& existing : connections_) {
        if (existing.source == entry.source && existing.destination == entry.destination) {
            existing.carrier = entry.carrier;
            existing.persistent = existing.persistent || entry.persistent;
            return proto::Ok{};
        }
    }
    if (connections_.size() >= max_connections)
        return proto::Error{"the name server already knows " + std::to_string(max_connections) +
                            " connections"};
    connections_.push_back(std::move(entry));
    return proto::Ok{};
}

proto::Status Registry::remove_connection(const std::string& source, const std::string& destination,
                                          std::uint64_t session) {
    if (auto owned = owns_source(source, session); !owned)
        return owned;
    auto before = connections_.size();
    std::erase_if(connections_, [&](const ConnectionEntry& c) {
        return c.source == source && c.destination == destination;
    });
    if (connections_.size() == before)
        return proto::Error{"no connection " + source + " -> " + destination};
    return proto::Ok{};
}

std::vector<ConnectionEntry> Registry::persistent_for(const std::string& port) const {
    std::vector<ConnectionEntry> out;
    for (const auto& c : connections_) {
        if (c.persistent && (c.source == port || c.destination == port))
            out.push_back(c);
    }
    return out;
}

std::vector<ConnectionEntry> Registry::persistent() const {
    std::vector<ConnectionEntry> out;
    std::copy_if(connections_.begin(), connections_.end(), std::back_inserter(out),
                 [](const ConnectionEntry& c) { return c.persistent; });
    return out;
}

void Registry::restore_persistent(std::vector<ConnectionEntry> entries) {
    for (auto& entry : entries) {
        entry.persistent = true;
        connections_.push_back(std::move(entry));
    }
}

void Registry::session_closed(std::uint64_t session, Clock::time_point now) {
    for (auto& [name, node] : nodes_) {
        if (node.session == session && session != 0) {
            node.session = 0;
            node.orphaned_at = now;
        }
    }
}

void Registry::remove_ports_of(const std::string& node, std::vector<std::string>& removed) {
    for (auto it = ports_.begin(); it != ports_.end();) {
        if (it->second.node == node) {
            const std::string name = it->first;
            removed.push_back(name);
            it = ports_.erase(it);
            release_mcast_group(name);
            std::erase_if(connections_, [&](const ConnectionEntry& c) {
                return !c.persistent && (c.source == name || c.destination == name);
            });
        } else {
            ++it;
        }
    }
}

std::vector<std::string> Registry::expire(Clock::time_point now) {
    std::vector<std::string> removed;
    for (auto it = nodes_.begin(); it != nodes_.end();) {
        if (it->second.session == 0 && now - it->second.orphaned_at >= grace_) {
            remove_ports_of(it->first, removed);
            it = nodes_.erase(it);
        } else {
            ++it;
        }
    }
    return removed;
}

nlohmann::json Registry::list() const {
    nlohmann::json ports = nlohmann::json::array();
    for (const auto& [name, entry] : ports_) {
        ports.push_back({{"name", name}, {"node", entry.node}, {"address", entry.address}});
    }
    nlohmann::json connections = nlohmann::json::array();
    for (const auto& c : connections_) {
        // qos as numbers for programs; 0 (unmarked, lowest) when the carrier asks for none.
        const auto carrier = proto::parse_carrier(c.carrier);
        const proto::Qos qos = carrier ? carrier->qos : proto::Qos{};
        connections.push_back({{"source", c.source},
                               {"destination", c.destination},
                               {"carrier", c.carrier},
                               {"dscp", qos.dscp.value_or(0)},
                               {"prio", qos.prio.value_or(0)},
                               {"persistent", c.persistent},
                               {"live", ports_.contains(c.source) && ports_.contains(c.destination)}});
    }
    return {{"ports", ports}, {"connections", connections}};
}

void Registry::release_mcast_group(const std::string& port) {
    auto it = mcast_groups_.find(port);
    if (it == mcast_groups_.end())
        return;
    mcast_released_.push_back(it->second);
    mcast_groups_.erase(it);
}

proto::Result<std::string> Registry::mcast_group(const std::string& port) {
    if (!ports_.contains(port))
        return proto::Error{"port " + port + " is not registered"};
    auto it = mcast_groups_.find(port);
    if (it == mcast_groups_.end()) {
        if (mcast_next_fresh_ >= mcast_count_ && mcast_released_.empty()) {
            return proto::Error{"all " + std::to_string(mcast_count_) +
                                " multicast groups of the name server's range are given out"};
        }
        std::uint32_t offset = 0;
        if (mcast_next_fresh_ < mcast_count_) {
            offset = mcast_next_fresh_++;
        } else {
            offset = mcast_released_.front();
            mcast_released_.pop_front();
        }
        it = mcast_groups_.emplace(port, offset).first;
    }
    const std::uint32_t address = mcast_first_ + it->second;
    return std::to_string(address >> 24) + "." + std::to_string((address >> 16) & 0xff) + "." +
           std::to_string((address >> 8) & 0xff) + "." + std::to_string(address & 0xff) + ":" +
           std::to_string(mcast_port_);
}

}  // namespace plexus::daemon::names
