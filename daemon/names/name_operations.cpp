// The name server's op table and its handlers, one per op (PROTOCOL.md, "Control operations").
#include <spdlog/spdlog.h>

#include <algorithm>
#include <iterator>

#include "name_server.hpp"

namespace plexus::daemon::names {

namespace {

using proto::Op;
using proto::ReplyCode;

std::string text_field(const nlohmann::json& body, const char* key) {
    auto it = body.find(key);
    return it != body.end() && it->is_string() ? it->get<std::string>() : std::string{};
}

proto::Reply ok(const proto::Request& request, nlohmann::json out = nlohmann::json::object()) {
    return proto::Reply{request.id, ReplyCode::ok, std::move(out)};
}

proto::Reply refuse(const proto::Request& request, const std::string& why,
                    ReplyCode code = ReplyCode::refused) {
    return proto::make_refusal(request.id, code, why);
}

proto::Reply status_reply(const proto::Request& request, const proto::Status& status) {
    return status ? ok(request) : refuse(request, status.error().message);
}

}  // namespace

// Look-ups anyone may make, also in one UDP datagram; the rest changes the registry or hands
// something out, and needs a TCP session (with a secret, one that proved it holds it).
const NameServer::Operation NameServer::operations_[] = {
    {Op::ping, Callers::anyone, &NameServer::ping},
    {Op::lookup, Callers::anyone, &NameServer::lookup},
    {Op::list, Callers::anyone, &NameServer::list},
    {Op::mcast_group, Callers::tcp, &NameServer::mcast_group},
    {Op::register_node, Callers::tcp, &NameServer::register_node},
    {Op::register_port, Callers::tcp, &NameServer::register_port},
    {Op::unregister_port, Callers::tcp, &NameServer::unregister_port},
    {Op::add_connection, Callers::tcp, &NameServer::add_connection},
    {Op::remove_connection, Callers::tcp, &NameServer::remove_connection},
};

proto::Reply NameServer::handle(const proto::Request& request, std::uint64_t session,
                                const SessionAddresses& where) {
    const std::string asked = request.body["op"];
    const auto op = proto::op_named(asked);
    const auto* row = std::find_if(std::begin(operations_), std::end(operations_),
                                   [&](const Operation& candidate) { return op && candidate.op == *op; });
    if (row == std::end(operations_))
        return refuse(request, "unknown request '" + asked + "'", ReplyCode::usage);
    if (row->callers == Callers::tcp && session == 0)
        return refuse(request, "'" + asked + "' is not available over UDP; use TCP", ReplyCode::usage);
    return (this->*(row->handler))(Asked{request, session, where});
}

proto::Reply NameServer::ping(const Asked& asked) {
    return ok(asked.request, {{"names", endpoint().text()},
                              {"auth_failures", auth_failures_},
                              {"handshake_timeouts", handshake_timeouts_}});
}

proto::Reply NameServer::lookup(const Asked& asked) {
    const std::string port = text_field(asked.request.body, "port");
    auto entry = registry_.lookup(port);
    if (!entry)
        return refuse(asked.request, "port " + port + " is not registered", ReplyCode::no);
    return ok(asked.request, {{"port", entry->name},
                              {"node", entry->node},
                              {"address", address_for(entry->address, asked.where)}});
}

proto::Reply NameServer::list(const Asked& asked) {
    auto listed = registry_.list();
    for (auto& port : listed["ports"])
        port["address"] = address_for(port["address"].get<std::string>(), asked.where);
    return ok(asked.request, std::move(listed));
}

proto::Reply NameServer::mcast_group(const Asked& asked) {
    auto group = registry_.mcast_group(text_field(asked.request.body, "port"));
    if (!group)
        return refuse(asked.request, group.error().message);
    return ok(asked.request, {{"group", *group}});
}

proto::Reply NameServer::register_node(const Asked& asked) {
    const auto& body = asked.request.body;
    const std::string node = text_field(body, "node");
    const std::string announced = text_field(body, "address");
    const std::string address = recorded_address(announced, asked.where);
    auto status = registry_.register_node(node, address, asked.session);
    if (status && address != announced)
        spdlog::info("names: node '{}' at {} (it announced {}: the address its session came from)", node,
                     address, announced);
    else if (status)
        spdlog::info("names: node '{}' at {}", node, address);
    return status_reply(asked.request, status);
}

proto::Reply NameServer::register_port(const Asked& asked) {
    const std::string port = text_field(asked.request.body, "port");
    auto status = registry_.register_port(port, asked.session);
    if (!status)
        return refuse(asked.request, status.error().message);
    nlohmann::json persistent = nlohmann::json::array();
    for (const auto& c : registry_.persistent_for(port))
        persistent.push_back({{"source", c.source}, {"destination", c.destination}, {"carrier", c.carrier}});
    return ok(asked.request, {{"persistent", persistent}});
}

proto::Reply NameServer::unregister_port(const Asked& asked) {
    return status_reply(asked.request,
                        registry_.unregister_port(text_field(asked.request.body, "port"), asked.session));
}

proto::Reply NameServer::add_connection(const Asked& asked) {
    const auto& body = asked.request.body;
    const bool persistent = body.value("persistent", false);
    auto status = registry_.add_connection({text_field(body, "source"), text_field(body, "destination"),
                                            text_field(body, "carrier"), persistent},
                                           asked.session);
    if (status && persistent)
        save_state();
    return status_reply(asked.request, status);
}

proto::Reply NameServer::remove_connection(const Asked& asked) {
    const auto& body = asked.request.body;
    const std::string source = text_field(body, "source");
    const std::string destination = text_field(body, "destination");
    const bool forget = body.value("forget", false);
    if (!forget) {
        // A connection that merely went down stays known when it is persistent.
        for (const auto& c : registry_.persistent()) {
            if (c.source == source && c.destination == destination)
                return ok(asked.request);
        }
    }
    auto status = registry_.remove_connection(source, destination, asked.session);
    if (forget)
        save_state();
    return status_reply(asked.request, status);
}

}  // namespace plexus::daemon::names
