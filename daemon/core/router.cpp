#include "router.hpp"

#include <algorithm>
#include <limits>

#include "batch.hpp"
#include "call_routing.hpp"
#include "plexus/proto/port_name.hpp"

namespace plexus::daemon {

proto::Result<std::shared_ptr<Port>> Router::open(const std::string& name, std::uint64_t owner,
                                                  QueuePolicy policy, std::size_t capacity,
                                                  std::size_t max_bytes) {
    if (auto error = proto::port_name_error(name))
        return proto::Error{*error};
    if (capacity == 0)
        return proto::Error{"queue capacity must be at least 1"};
    if (ports_.contains(name))
        return proto::Error{"port " + name + " is already open on this daemon"};
    auto port = std::make_shared<Port>(name, owner, policy, capacity, max_bytes);
    ports_.emplace(name, port);
    return port;
}

std::vector<std::shared_ptr<Connection>> Router::close(const std::string& name) {
    std::vector<std::shared_ptr<Connection>> removed;
    auto it = ports_.find(name);
    if (it == ports_.end())
        return removed;
    auto port = it->second;
    ports_.erase(it);
    for (auto& connection : port->outgoing) {
        connection->close_after_flush();
        removed.push_back(connection);
    }
    port->outgoing.clear();
    for (auto& [other_name, other] : ports_) {
        auto& out = other->outgoing;
        for (auto c = out.begin(); c != out.end();) {
            if (!(*c)->remote && (*c)->destination == name) {
                removed.push_back(*c);
                c = out.erase(c);
            } else {
                ++c;
            }
        }
    }
    port->mark_closed();
    return removed;
}

std::shared_ptr<Port> Router::find(const std::string& name) const {
    auto it = ports_.find(name);
    return it == ports_.end() ? nullptr : it->second;
}

proto::Status Router::add(const std::shared_ptr<Port>& source, std::shared_ptr<Connection> connection) {
    for (const auto& existing : source->outgoing) {
        if (existing->destination == connection->destination) {
            return proto::Error{"ports " + connection->source + " and " + connection->destination +
                                " are already connected"};
        }
    }
    // Kept in descending qos.prio, in the order made among equals: a message reaches (and wakes
    // the link of) a connection of higher priority before any of lower priority.
    if (crossing_for)
        connection->crossing = crossing_for(*source, connection->sink);
    auto& out = source->outgoing;
    const auto place = std::find_if(out.begin(), out.end(), [&](const std::shared_ptr<Connection>& c) {
        return c->priority < connection->priority;
    });
    out.insert(place, std::move(connection));
    return proto::Ok{};
}

std::shared_ptr<Connection> Router::remove(const std::string& source, const std::string& destination) {
    auto port = find(source);
    if (!port)
        return nullptr;
    auto& out = port->outgoing;
    auto it = std::find_if(out.begin(), out.end(), [&](auto& c) { return c->destination == destination; });
    if (it == out.end())
        return nullptr;
    auto connection = *it;
    out.erase(it);
    connection->close_after_flush();
    return connection;
}

bool Router::remove(const std::shared_ptr<Connection>& connection) {
    auto port = find(connection->source);
    if (!port)
        return false;
    auto& out = port->outgoing;
    auto it = std::find(out.begin(), out.end(), connection);
    if (it == out.end())
        return false;
    out.erase(it);
    return true;
}

bool Router::blocked(const Port& source) {
    return std::any_of(source.outgoing.begin(), source.outgoing.end(),
                       [](const auto& c) { return c->room() == 0; });
}

std::size_t Router::room(const Port& source) {
    std::size_t room = std::numeric_limits<std::size_t>::max();
    for (const auto& connection : source.outgoing)
        room = std::min(room, connection->room());
    return room;
}

void Router::route(Port& source, const Message& message) {
    source.written += message.count();
    if (source.outgoing.empty())
        source.unconnected += message.count();  // pub-sub: nobody to send to, but say how many
    for (auto& connection : source.outgoing) {
        if (connection->route_constraint && !route_holds(source, *connection)) {
            connection->dropped_by_route += message.count();
            continue;
        }
        connection->sent += message.count();
        if (!connection->send_monitors) {
            connection->way_out().deliver(message);  // a batch stays whole unless the sink splits it
            continue;
        }
        // The monitors see records one by one; what they pass reaches the sink through
        // Connection::filtered.
        connection->send_monitors->submit(message);
    }
}

}  // namespace plexus::daemon
