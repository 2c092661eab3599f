#include "call_routing.hpp"

#include <mutex>

namespace plexus::daemon {

bool route_holds(const Port& source, const Connection& connection) {
    if (!connection.route_constraint)
        return true;
    if (!source.arbiter)  // nothing ever connected into the port: no event can be present
        return connection.route_constraint->evaluate([](const std::string&) { return false; });
    auto& arbiter = *source.arbiter;
    std::lock_guard lock(arbiter.mutex());
    const double now = arbiter.now();
    return connection.route_constraint->evaluate(
        [&](const std::string& name) { return arbiter.events().has(name, now); });
}

std::variant<Connection*, std::string> choose_server(const Port& source) {
    if (source.outgoing.empty()) {
        return "port " + source.name() +
               " has no connection to a server: connect it to the port that serves (plexus connect " +
               source.name() + " SERVER)";
    }
    std::string waiting;
    for (const auto& connection : source.outgoing) {
        if (!connection->carries_calls()) {
            waiting += "; " + connection->source + " -> " + connection->destination + " is " +
                       connection->carrier.substr(0, connection->carrier.find('+')) +
                       ", a datagram carrier, which carries no calls (use tcp or local)";
            continue;
        }
        if (route_holds(source, *connection))
            return connection.get();
        waiting += "; " + connection->source + " -> " + connection->destination + " takes calls while '" +
                   connection->route_constraint->text() + "', false now";
    }
    return "no server of " + source.name() + " is selectable now" + waiting;
}

void send_call(Connection& connection, const Message& call) {
    ++connection.calls;
    ++connection.sent;
    if (connection.send_monitors)
        connection.send_monitors->submit(call);
    else
        connection.way_out().deliver(call);
}

}  // namespace plexus::daemon
