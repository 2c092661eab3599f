// The name server's op table and its handlers, one per op (PROTOCOL.md, "Control operations").
#include <spdlog/spdlog.h>

#include <algorithm>
#include <iterator>
#include <optional>

#include "name_server.hpp"
#include "plexus/proto/name_operations.hpp"

namespace plexus::daemon::names {

namespace {

using proto::Op;
using proto::ReplyCode;

/// The answer to `request`: a reply struct of plexus/proto/name_operations.hpp, encoded.
template <class Answer>
proto::Reply ok(const proto::Request& request, const Answer& answer) {
    return proto::Reply{request.id, ReplyCode::ok, answer.encode()};
}

proto::Reply refuse(const proto::Request& request, const std::string& why,
                    ReplyCode code = ReplyCode::refused) {
    return proto::make_refusal(request.id, code, why);
}

proto::Reply status_reply(const proto::Request& request, const proto::Status& status) {
    return status ? ok(request, proto::EmptyReply{}) : refuse(request, status.error().message);
}

/// The request's fields in `Request`'s struct, or (in `refusal`) the usage error that answers a
/// field of the wrong type.
template <class Request>
std::optional<Request> decode(const proto::Request& request, proto::Reply& refusal) {
    auto decoded = Request::decode(request.body);
    if (!decoded) {
        refusal = refuse(request, decoded.error().message, ReplyCode::usage);
        return std::nullopt;
    }
    return std::move(*decoded);
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
                                const SessionAddresses& where, const proto::Subject* certified) {
    const std::string asked = request.body["op"];
    const auto op = proto::op_named(asked);
    const auto* row = std::find_if(std::begin(operations_), std::end(operations_),
                                   [&](const Operation& candidate) { return op && candidate.op == *op; });
    if (row == std::end(operations_))
        return refuse(request, "unknown request '" + asked + "'", ReplyCode::usage);
    if (row->callers == Callers::tcp && session == 0)
        return refuse(request, "'" + asked + "' is not available over UDP; use TCP", ReplyCode::usage);
    return (this->*(row->handler))(Asked{request, session, where, certified});
}

// Every handler decodes its request first: a field of the wrong type is answered with code 2.

proto::Reply NameServer::ping(const Asked& asked) {
    proto::Reply refusal;
    if (!decode<proto::PingRequest>(asked.request, refusal))
        return refusal;
    return ok(asked.request, proto::NamesPingReply{endpoint().text(), auth_failures_, handshake_timeouts_,
                                                   tls_records_refused_, peers_refused_, identity_refusals_,
                                                   permissions_.refusals()});
}

proto::Reply NameServer::lookup(const Asked& asked) {
    proto::Reply refusal;
    const auto request = decode<proto::LookupRequest>(asked.request, refusal);
    if (!request)
        return refusal;
    const std::string& port = request->port;
    auto entry = registry_.lookup(port);
    if (!entry)
        return refuse(asked.request, "port " + port + " is not registered", ReplyCode::no);
    return ok(asked.request,
              proto::LookupReply{entry->name, entry->node, address_for(entry->address, asked.where)});
}

proto::Reply NameServer::list(const Asked& asked) {
    proto::Reply refusal;
    if (!decode<proto::ListRequest>(asked.request, refusal))
        return refusal;
    auto listed = registry_.list();
    for (auto& port : listed["ports"])
        port["address"] = address_for(port["address"].get<std::string>(), asked.where);
    return ok(asked.request, proto::ListReply{std::move(listed)});
}

proto::Reply NameServer::mcast_group(const Asked& asked) {
    proto::Reply refusal;
    const auto request = decode<proto::McastGroupRequest>(asked.request, refusal);
    if (!request)
        return refusal;
    auto group = registry_.mcast_group(request->port);
    if (!group)
        return refuse(asked.request, group.error().message);
    return ok(asked.request, proto::McastGroupReply{*group});
}

proto::Reply NameServer::register_node(const Asked& asked) {
    proto::Reply refusal;
    const auto request = decode<proto::RegisterNodeRequest>(asked.request, refusal);
    if (!request)
        return refusal;
    const std::string& node = request->node;
    const std::string& announced = request->address;
    // With identities a node name is bound to its certificate: only the holder of node N's may
    // register N (and so its ports and its address).
    if (config_.secret && config_.secret->identity()) {
        const auto* certified = asked.certified;
        if (!certified || certified->kind != proto::Subject::Kind::node || certified->name != node) {
            ++identity_refusals_;
            const std::string holder = certified ? certified->text() : std::string("no certificate");
            spdlog::warn("names: refused to register node '{}' for a peer holding {}", node, holder);
            return refuse(asked.request, "node '" + node +
                                             "' may only be registered with its own certificate; this "
                                             "peer holds " +
                                             holder);
        }
    }
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
    proto::Reply refusal;
    const auto request = decode<proto::RegisterPortRequest>(asked.request, refusal);
    if (!request)
        return refusal;
    const std::string& port = request->port;
    if (permissions_.enforcing()) {
        const Principal who{.node = registry_.node_named_by(asked.session)};
        if (auto allowed = permissions_.check(who, Action::open, port, "names: "); !allowed)
            return refuse(asked.request, allowed.error().message);
    }
    auto status = registry_.register_port(port, asked.session);
    if (!status)
        return refuse(asked.request, status.error().message);
    proto::RegisterPortReply answer;
    for (const auto& c : registry_.persistent_for(port))
        answer.persistent.push_back({c.source, c.destination, c.carrier});
    return ok(asked.request, answer);
}

proto::Reply NameServer::unregister_port(const Asked& asked) {
    proto::Reply refusal;
    const auto request = decode<proto::UnregisterPortRequest>(asked.request, refusal);
    if (!request)
        return refusal;
    return status_reply(asked.request, registry_.unregister_port(request->port, asked.session));
}

proto::Reply NameServer::add_connection(const Asked& asked) {
    proto::Reply refusal;
    const auto request = decode<proto::AddConnectionRequest>(asked.request, refusal);
    if (!request)
        return refusal;
    auto status = registry_.add_connection(
        {request->source, request->destination, request->carrier, request->persistent}, asked.session);
    if (status && request->persistent)
        save_state();
    return status_reply(asked.request, status);
}

proto::Reply NameServer::remove_connection(const Asked& asked) {
    proto::Reply refusal;
    const auto request = decode<proto::RemoveConnectionRequest>(asked.request, refusal);
    if (!request)
        return refusal;
    const std::string& source = request->source;
    const std::string& destination = request->destination;
    const bool forget = request->forget;
    if (!forget) {
        // A connection that merely went down stays known when it is persistent.
        for (const auto& c : registry_.persistent()) {
            if (c.source == source && c.destination == destination)
                return ok(asked.request, proto::RemoveConnectionReply{});
        }
    }
    auto status = registry_.remove_connection(source, destination, asked.session);
    if (forget)
        save_state();
    return status_reply(asked.request, status);
}

}  // namespace plexus::daemon::names
