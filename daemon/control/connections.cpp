// Connections between ports: `connect` (both ends here, or the sending end of one to another
// daemon), `attach` (the receiving end of one from another daemon), `disconnect`, and the
// connections the name server remembers. What differs from carrier to carrier is the carrier's
// (net/carriers/): here a carrier is looked up in the table and asked for its ends.
#include <utility>

#include <spdlog/spdlog.h>

#include "arbitration/carrier_rules.hpp"
#include "control_plane.hpp"
#include "core/router.hpp"
#include "monitor_wiring.hpp"
#include "names/name_client.hpp"
#include "net/carriers/carrier_table.hpp"
#include "net/session.hpp"
#include "plexus/proto/carrier.hpp"
#include "plexus/proto/port_name.hpp"
#include "request_fields.hpp"
#include "wire_inlet.hpp"

namespace plexus::daemon {

namespace {
using proto::ReplyCode;

/// The carrier's parsed text (empty when it does not parse: it was checked before).
proto::Carrier parsed_or_empty(const std::string& carrier_text) {
    auto parsed = proto::parse_carrier(carrier_text);
    return parsed ? *parsed : proto::Carrier{};
}

}  // namespace

carriers::SendStageMaker ControlPlane::send_stage_maker(std::shared_ptr<monitor::MonitorChain> chain) {
    if (!chain)
        return {};
    // The chain moves into the one stage made: from then on its monitors belong to that stage's
    // worker (which lets them go there), not to whoever still holds this function.
    return
        [&scripts = host_.scripts(), chain = std::move(chain)](
            std::weak_ptr<FilterClient> client, bool drop_oldest) mutable -> std::shared_ptr<MessageFilter> {
            if (!chain)
                return nullptr;
            monitor::MonitorStage::Options options;
            options.drop_oldest = drop_oldest;
            return scripts.make_stage(std::exchange(chain, nullptr), nullptr, options, std::move(client));
        };
}

Task<proto::Reply> ControlPlane::connect(std::shared_ptr<Session> session, const proto::Request& request) {
    auto decoded = proto::ConnectRequest::decode(request.body);
    if (!decoded)
        co_return malformed(decoded.error());
    const proto::ConnectRequest asked = std::move(*decoded);
    const std::string source = asked.source;
    const std::string destination = asked.destination;
    std::string carrier_text = asked.carrier;
    for (const auto& name : {source, destination}) {
        if (auto error = proto::port_name_error(name))
            co_return refuse(*error, ReplyCode::usage);
    }
    bool automatic = carrier_text.empty();
    proto::Carrier carrier;
    if (!automatic) {
        auto parsed = proto::parse_carrier(carrier_text);
        if (!parsed)
            co_return refuse("bad carrier: " + parsed.error().message);
        if (auto valid = proto::validate_carrier(*parsed); !valid)
            co_return refuse(valid.error().message);
        carrier = std::move(*parsed);
        carrier_text = carrier.text();
    }
    auto& router = host_.router();
    auto port = router.find(source);
    auto local_destination = router.find(destination);
    // Every daemon the request passes checks its asker: here a local user or the node that
    // forwarded it; the source's daemon also checks what the connection itself needs.
    if (auto allowed =
            connect_permitted(session.get(), carrier, source, destination, port && local_destination);
        !allowed)
        co_return refuse(allowed.error().message);
    if (!port)
        co_return co_await forward(request, asked.forwarded, source);
    // The send-side monitors run here whatever the destination; made first, so that a script
    // that fails leaves nothing behind.
    auto send_chain = host_.scripts().build_chain(carrier, proto::Side::send, source, destination);
    if (!send_chain)
        co_return refuse(send_chain.error().message);
    auto route = arbitration::route_constraint(carrier);
    if (!route)
        co_return refuse(route.error().message);

    // No carrier named: the table's choice (local when both ports are here, else tcp). A carrier
    // between daemons named explicitly goes through the network even between ports of this daemon
    // (over loopback); only a carrier within the daemon (`local`), or none, stays in it.
    const carriers::Carrier* chosen = &carriers::automatic_carrier(local_destination != nullptr);
    if (!automatic) {
        auto found = carriers::find_carrier(carrier.base);
        if (!found)
            co_return refuse(found.error().message);
        chosen = *found;
    }
    const std::string base(chosen->name());
    if (chosen->within_daemon()) {
        if (!local_destination) {
            co_return refuse("carrier '" + std::string(chosen->name()) +
                             "' needs both ports on one daemon, and " + destination + " is not on this one");
        }
        auto connection = std::make_shared<Connection>();
        connection->source = source;
        connection->destination = destination;
        connection->carrier = automatic ? base : carrier_text;
        connection->priority = carrier.qos.prio.value_or(0);
        connection->route_constraint = *route;
        const InletSpec spec{local_destination, source, carrier, connection->carrier, asked.strict};
        carriers::SendingContext context{.host = host_,
                                         .request = {},
                                         .carrier = carrier,
                                         .link = nullptr,
                                         .endpoint = {},
                                         .attached = {},
                                         .inlet = nullptr,
                                         .connection = connection,
                                         .make_send_stage = send_stage_maker(std::move(*send_chain))};
        context.request.source = source;
        context.request.destination = destination;
        context.request.carrier = connection->carrier;
        context.request.strict = asked.strict;
        // The connection takes its sending end (the inlet) before the inlet joins its port: a pair
        // already connected is refused with nothing joined.
        const InletHandOver hand_over = [&](const std::shared_ptr<Inlet>& inlet) -> proto::Status {
            context.inlet = inlet;
            auto end = chosen->make_sending_end(context);
            if (!end)
                return end.error();
            connection->sink = end->sink;
            connection->send_monitors = end->send_monitors;
            return router.add(port, connection);
        };
        auto wired = wire_inlet(host_.scripts(), host_.clock(), spec, hand_over);
        if (!wired)
            co_return refuse(wired.error().message);
        connection->persistent = asked.persist;
        names::ConnectionEntry entry{source, destination, connection->carrier, connection->persistent};
        co_await host_.names().add_connection(std::move(entry));
        spdlog::info("connected {} -> {} ({})", source, destination, connection->carrier);
        co_return ok(proto::ConnectReply{connection->carrier, wired->warnings});
    }
    std::string where;
    std::string node;
    if (local_destination) {
        where = host_.address();
        node = host_.config().node;
    } else {
        auto looked_up = co_await host_.names().lookup(destination);
        if (!looked_up)
            co_return refuse(looked_up.error().message);
        where = looked_up->address;
        node = looked_up->node;
        // The destination's node reads the source: it must be allowed to.
        if (permissions_.enforcing()) {
            if (auto allowed = permitted(Principal{.node = node}, Action::read, source); !allowed)
                co_return refuse(allowed.error().message);
        }
    }
    std::string chosen_text = carrier_text;
    if (automatic)
        chosen_text = base;
    std::shared_ptr<monitor::MonitorChain> chain = std::move(*send_chain);
    co_return co_await connect_remote(asked, port, chosen_text, chosen, where, node, chain,
                                      std::move(*route));
}

Task<proto::Reply> ControlPlane::connect_remote(proto::ConnectRequest asked, std::shared_ptr<Port> port,
                                                std::string carrier, const carriers::Carrier* chosen,
                                                std::string address, std::string node,
                                                std::shared_ptr<monitor::MonitorChain> send_chain,
                                                std::optional<arbitration::Constraint> route) {
    const std::string source = port->name();
    const std::string destination = asked.destination;
    for (const auto& existing : port->outgoing) {
        if (existing->destination == destination)
            co_return refuse("ports " + source + " and " + destination + " are already connected");
    }
    auto endpoint = proto::parse_endpoint(address);
    if (!endpoint)
        co_return refuse("the name server gave a bad address for " + destination + ": " + address);
    auto link = co_await open_link(port, chosen, destination, carrier, *endpoint, node, asked.strict);
    if (!link.peer)
        co_return link.answer;
    const proto::Carrier parsed = parsed_or_empty(carrier);
    auto connection = std::make_shared<Connection>();
    connection->source = source;
    connection->destination = destination;
    connection->carrier = carrier;
    connection->remote = true;
    connection->priority = parsed.qos.prio.value_or(0);
    connection->persistent = asked.persist;
    connection->route_constraint = std::move(route);
    carriers::SendingContext context{.host = host_,
                                     .request = link.request,
                                     .carrier = parsed,
                                     .link = link.peer,
                                     .endpoint = *endpoint,
                                     .attached = link.attached,
                                     .inlet = nullptr,
                                     .connection = connection,
                                     .make_send_stage = send_stage_maker(std::move(send_chain))};
    auto end = chosen->make_sending_end(context);
    if (!end) {
        link.peer->close("no sending end");
        co_return refuse(end.error().message);
    }
    connection->sink = end->sink;
    connection->send_monitors = end->send_monitors;
    if (auto added = host_.router().add(port, connection); !added) {
        link.peer->close("duplicate");
        co_return refuse(added.error().message);
    }
    host_.keep_link(link.peer);
    watch_link(link.peer, end->queue, connection);
    names::ConnectionEntry entry{source, destination, carrier, connection->persistent};
    co_await host_.names().add_connection(std::move(entry));
    spdlog::info("connected {} -> {} ({} to {})", source, destination, carrier, address);
    co_return ok(proto::ConnectReply{carrier, link.attached.warnings});
}

Task<ControlPlane::AttachedLink> ControlPlane::open_link(std::shared_ptr<Port> port,
                                                         const carriers::Carrier* chosen,
                                                         std::string destination, std::string carrier,
                                                         proto::Endpoint endpoint, std::string node,
                                                         bool strict) {
    const std::string source = port->name();
    AttachedLink end;
    proto::AttachRequest request;
    request.source = source;
    request.destination = destination;
    request.carrier = carrier;
    request.strict = strict;
    // What the carrier adds to the attach request (mcast: the port's group) it may have to ask
    // for; a refusal here opens no link.
    auto prepared = co_await chosen->prepare_attach(host_, request);
    if (!prepared) {
        end.answer = refuse(prepared.error().message);
        co_return end;
    }
    end.request = std::move(*prepared);
    const proto::Hello hello = our_hello("link");
    const auto secret = host_.config().secret;
    auto peer = co_await Peer::connect(executor_, endpoint, hello, host_.config().max_frame, peer_timeout,
                                       space_notifier(), secret);
    if (!peer) {
        end.answer = refuse("cannot reach the daemon of " + destination + ": " + peer.error().message);
        co_return end;
    }
    auto link_peer = *peer;
    link_peer->set_description("link " + source + " -> " + destination);
    // With identities a daemon's hello names its certificate's node (FramedConnection): the one
    // reached must be the node the name server gives for the destination, not a host on the path
    // that answers in its place with a certificate of its own.
    if (secret && secret->identity() && link_peer->peer_hello().node != node) {
        link_peer->close("not the destination's node");
        end.answer = refuse("the daemon at " + endpoint.text() + " is node '" + link_peer->peer_hello().node +
                            "', not node '" + node + "' that the name server gives for " + destination);
        co_return end;
    }
    // qos.dscp marks the link's socket: every connection has a link socket of its own, so the
    // mark is this connection's alone (udp and mcast mark their datagrams themselves).
    const proto::Qos qos = parsed_or_empty(carrier).qos;
    if (qos.dscp) {
        if (auto marked = link_peer->mark_packets(*qos.dscp); !marked) {
            link_peer->close("cannot mark packets");
            end.answer = refuse(marked.error().message);
            co_return end;
        }
    }
    // The receiving daemon wires its end (monitors, arbitration) while it answers attach.
    const nlohmann::json attach_body = end.request.encode();
    auto replied = co_await link_peer->request(attach_body, peer_timeout);
    if (!replied || replied->code != ReplyCode::ok) {
        link_peer->close("attach refused");
        end.answer = replied ? *replied : refuse(replied.error().message);
        co_return end;
    }
    auto attached = proto::AttachReply::decode(replied->body);
    if (!attached) {
        link_peer->close("bad attach answer");
        end.answer = refuse(attached.error().message);
        co_return end;
    }
    if (port->closed()) {
        link_peer->close("source closed");
        end.answer = refuse("port " + source + " closed while connecting");
        co_return end;
    }
    end.answer = *replied;
    end.attached = *attached;
    end.peer = link_peer;
    co_return end;
}

void ControlPlane::watch_link(std::shared_ptr<Peer> link, std::shared_ptr<const ReaderQueue> queue,
                              const std::shared_ptr<Connection>& connection) {
    std::weak_ptr<Connection> weak = connection;
    // The queue is held here, not reached through the connection: after a disconnect the
    // connection is gone while the link still drains, and what it could not send must be counted.
    link->closed_handler = [this, &host = host_, weak, queue = std::move(queue), source = connection->source,
                            destination = connection->destination](const std::string& reason) {
        if (queue && queue->depth() > 0) {
            host.counters().dropped_link_down += queue->depth();
            spdlog::warn("connection {} -> {} lost {} queued messages: {}", source, destination,
                         queue->depth(), reason);
        }
        auto c = weak.lock();
        if (!c)
            return;
        if (host.router().remove(c)) {
            spdlog::info("connection {} -> {} went down: {}", c->source, c->destination, reason);
            host.notify_space();
            if (!host.stopping())
                host.names().notify_connection_down(c->source, c->destination);
            if (!host.stopping() && c->persistent) {
                asio::co_spawn(executor_,
                               remake_persistent({c->source, c->destination, c->carrier, c->persistent}),
                               asio::detached);
            }
        }
    };
}

Task<proto::Reply> ControlPlane::attach(std::shared_ptr<Session> session, const proto::Request& request) {
    const auto asked = proto::AttachRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    const std::string destination = asked->destination;
    auto port = host_.router().find(destination);
    if (!port)
        co_return refuse("port " + destination + " does not exist on node '" + host_.config().node + "'");
    if (session->is_link())
        co_return refuse("this link is already attached", ReplyCode::usage);
    const std::string source = asked->source;
    if (auto error = proto::port_name_error(source))
        co_return refuse(*error, ReplyCode::usage);
    auto carrier = proto::parse_carrier(asked->carrier);
    if (!carrier)
        co_return refuse("bad carrier: " + carrier.error().message);
    if (auto valid = proto::validate_carrier(*carrier); !valid)
        co_return refuse(valid.error().message);
    auto found = carriers::find_carrier(carrier->base);
    if (!found)
        co_return refuse(found.error().message);
    const carriers::Carrier* chosen = *found;
    // A link carries only a source that lives on its own node (the node its hello named, which the
    // deployment secret vouches for): no daemon feeds another's port under a third one's name.
    const std::string link_node = session->peer_hello().node;
    auto owner = co_await host_.names().lookup(source);
    if (!owner)
        co_return refuse("cannot attach " + source + ": " + owner.error().message);
    if (owner->node != link_node) {
        co_return refuse("port " + source + " lives on node '" + owner->node +
                         "', and this link comes from node '" + link_node + "': refused");
    }
    // The linking node writes into the destination, and runs monitors on it if it asks for any.
    // A link of this daemon's own (a carrier between daemons named for two ports of this one) was
    // checked when its connect was asked for, as a local connection is.
    const bool own_link = link_node == host_.config().node;
    if (auto allowed =
            own_link ? proto::Status(proto::Ok{}) : permitted(session.get(), Action::write, destination);
        !allowed)
        co_return refuse(allowed.error().message);
    for (const auto& clause : carrier->clauses) {
        if (clause.side != proto::Side::recv || own_link)
            continue;
        if (auto allowed = permitted(session.get(), Action::monitor, destination); !allowed)
            co_return refuse(allowed.error().message);
        break;
    }
    const InletSpec spec{port, source, *carrier, carrier->text(), asked->strict};
    auto wired = wire_inlet(host_.scripts(), host_.clock(), spec);
    if (!wired)
        co_return refuse(wired.error().message);
    // The sending daemon shapes its end after this port's queue (a latest port gets a latest link).
    proto::AttachReply answer;
    answer.warnings = wired->warnings;
    answer.policy = queue_policy_name(port->queue().policy());
    answer.capacity = port->queue().capacity();
    // What feeds the inlet besides the link session's own data frames is the carrier's.
    const carriers::ReceivingContext context{
        .host = host_, .session = session, .request = *asked, .carrier = *carrier, .inlet = wired->inlet};
    auto received = co_await chosen->attach_receiving_end(context, answer);
    if (!received)
        co_return refuse(received.error().message);
    answer = std::move(*received);
    if (carrier->qos.dscp) {
        // This end sends the acknowledgements and replies of the connection's link: same mark.
        if (auto marked = session->mark_packets(*carrier->qos.dscp); !marked)
            spdlog::warn("link {} -> {}: {}", source, destination, marked.error().message);
    }
    session->become_link(wired->inlet);
    std::weak_ptr<Session> weak = session;
    port->on_close(weak, [weak] {
        if (auto s = weak.lock())
            s->close("destination port closed");
    });
    session->set_description("link " + source + " -> " + destination);
    co_return ok(answer);
}

Task<proto::Reply> ControlPlane::disconnect(std::shared_ptr<Session> session, const proto::Request& request) {
    const auto asked = proto::DisconnectRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    const std::string source = asked->source;
    const std::string destination = asked->destination;
    if (auto allowed = permitted(session.get(), Action::connect, source); !allowed)
        co_return refuse(allowed.error().message);
    if (!host_.router().find(source))
        co_return co_await forward(request, asked->forwarded, source);
    auto removed = host_.router().remove(source, destination);
    if (!removed && remaking_.erase(source + " -> " + destination) > 0) {
        // Down, and being made again: disconnecting ends that, and the name server forgets it.
        co_await host_.names().remove_connection(source, destination, true);
        spdlog::info("disconnected {} -> {} (it was down)", source, destination);
        co_return ok(proto::DisconnectReply{});
    }
    if (!removed)
        co_return refuse("ports " + source + " and " + destination + " are not connected", ReplyCode::no);
    host_.notify_space();
    co_await host_.names().remove_connection(source, destination, true);
    spdlog::info("disconnected {} -> {}", source, destination);
    co_return ok(proto::DisconnectReply{});
}

Task<void> ControlPlane::remake_persistent(names::ConnectionEntry entry) {
    const std::string key = entry.source + " -> " + entry.destination;
    if (!remaking_.insert(key).second)
        co_return;  // already at it
    const std::weak_ptr<void> alive = alive_;
    proto::ConnectRequest asked;
    asked.source = entry.source;
    asked.destination = entry.destination;
    asked.carrier = entry.carrier;
    asked.persist = true;
    proto::Request request;
    request.body = asked.encode();
    auto delay = std::chrono::milliseconds(100);
    constexpr auto longest = std::chrono::milliseconds(5000);
    for (int attempt = 1;; ++attempt) {
        asio::steady_timer pause(executor_, delay);
        co_await pause.async_wait(use_nothrow);
        delay = std::min(delay * 2, longest);
        if (alive.expired())
            co_return;  // the control plane is gone
        if (host_.stopping() || !remaking_.contains(key) || !host_.router().find(entry.source))
            break;
        if (const auto where = co_await host_.names().lookup(entry.destination); !where) {
            spdlog::info("persistent connection {}: not made again for now: {}", key, where.error().message);
            break;  // gone, or the name server is: its registration restores the connection
        }
        if (alive.expired())
            co_return;
        if (!remaking_.contains(key))
            break;
        const std::shared_ptr<Session> no_session;
        const auto reply = co_await connect(no_session, request);
        if (alive.expired())
            co_return;
        const std::string error = reply.body.value("error", std::string{});
        if (reply.code == ReplyCode::ok || error.find("already connected") != std::string::npos) {
            spdlog::info("persistent connection {} made again (attempt {})", key, attempt);
            break;
        }
        spdlog::debug("persistent connection {}: attempt {} failed: {}", key, attempt, error);
    }
    remaking_.erase(key);
}

Task<void> ControlPlane::restore_persistent(std::vector<names::ConnectionEntry> persistent) {
    for (const auto& entry : persistent) {
        proto::ConnectRequest asked;
        asked.source = entry.source;
        asked.destination = entry.destination;
        asked.carrier = entry.carrier;
        asked.persist = entry.persistent;  // still persistent: made again if its link breaks
        proto::Request request;
        request.body = asked.encode();
        // Either end may come up first; the one that comes second makes the connection, so a
        // failure here (the other end is not there yet) is expected and only logged. The daemon
        // asks itself: there is no session.
        const std::shared_ptr<Session> no_session;
        auto reply = co_await connect(no_session, request);
        if (reply.code == ReplyCode::ok) {
            spdlog::info("restored persistent connection {} -> {}", entry.source, entry.destination);
        } else {
            spdlog::debug("persistent connection {} -> {} not restored yet: {}", entry.source,
                          entry.destination, reply.body.value("error", std::string{}));
        }
    }
}

}  // namespace plexus::daemon
