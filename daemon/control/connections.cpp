// Connections between ports: `connect` (both ends here, or the sending end of one to another
// daemon), `attach` (the receiving end of one from another daemon), `disconnect`, and the
// connections the name server remembers.
#include <spdlog/spdlog.h>

#include "control_plane.hpp"
#include "core/router.hpp"
#include "names/name_client.hpp"
#include "net/carriers/mcast.hpp"
#include "net/carriers/tcp.hpp"
#include "net/carriers/udp.hpp"
#include "net/session.hpp"
#include "plexus/proto/carrier.hpp"
#include "plexus/proto/port_name.hpp"
#include "request_fields.hpp"
#include "script_host.hpp"
#include "wire_inlet.hpp"

namespace plexus::daemon {

namespace {
using proto::ReplyCode;

/// True when the carrier text's base is `base` ("udp", "mcast").
bool has_base(const std::string& carrier_text, const std::string& base) {
    return carrier_text == base || carrier_text.rfind(base + "+", 0) == 0;
}

/// The send-side clauses of a carrier, as text ("" when none): what mcast connections of one port
/// must agree on.
std::string send_clauses(const std::string& carrier_text) {
    auto parsed = proto::parse_carrier(carrier_text);
    if (!parsed)
        return {};
    proto::Carrier sends;
    sends.base = parsed->base;
    for (const auto& clause : parsed->clauses) {
        if (clause.side == proto::Side::send)
            sends.clauses.push_back(clause);
    }
    return sends.clauses.empty() ? std::string{} : sends.text();
}

/// The carrier's qos settings (none when the text does not parse: it was checked before).
proto::Qos qos_of(const std::string& carrier_text) {
    auto parsed = proto::parse_carrier(carrier_text);
    return parsed ? parsed->qos : proto::Qos{};
}

/// "A.B.C.D:PORT" as a multicast endpoint; nullopt when it is not one.
std::optional<asio::ip::udp::endpoint> group_endpoint(const std::string& text) {
    auto parsed = proto::parse_endpoint(text);
    if (!parsed)
        return std::nullopt;
    boost::system::error_code ec;
    const auto address = asio::ip::make_address(parsed->host, ec);
    if (ec || !address.is_multicast() || parsed->port == 0)
        return std::nullopt;
    return asio::ip::udp::endpoint(address, parsed->port);
}
/// The send-side monitors of a connection on a worker of their own, in front of its sink; null
/// without monitors. A sink that never holds the writer back (latest, datagrams) makes the
/// monitors drop their oldest waiting message when they fall behind, rather than hold it back.
std::shared_ptr<MessageFilter> send_stage(ScriptHost& scripts, std::shared_ptr<monitor::MonitorChain> chain,
                                          const std::shared_ptr<Connection>& connection) {
    if (!chain)
        return nullptr;
    monitor::MonitorStage::Options options;
    options.drop_oldest = connection->sink->room() >= (std::size_t{1} << 30);
    return scripts.make_stage(std::move(chain), nullptr, options, connection);
}

}  // namespace

proto::Result<std::shared_ptr<MessageSink>> ControlPlane::udp_sending_end(std::shared_ptr<Peer> link,
                                                                          const proto::Endpoint& endpoint,
                                                                          const proto::AttachReply& attached,
                                                                          std::string description,
                                                                          std::optional<int> dscp) {
    const std::uint64_t port = attached.udp_port.value_or(0);
    const std::uint64_t stream = attached.stream;
    boost::system::error_code ec;
    const auto address = asio::ip::make_address(endpoint.host, ec);
    if (port == 0 || port > 65535 || stream == 0 || ec) {
        return proto::Error{
            "the daemon at " + endpoint.text() +
            " gave no usable udp port and stream for this connection (udp needs IP addresses)"};
    }
    asio::ip::udp::endpoint to(address, static_cast<std::uint16_t>(port));
    std::shared_ptr<MessageSink> sink = std::make_shared<carriers::UdpLink>(
        host_.udp(), to, stream, std::move(link), std::move(description), dscp);
    return sink;
}

Task<proto::Reply> ControlPlane::connect(std::shared_ptr<Session>, const proto::Request& request) {
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
    if (!port)
        co_return co_await forward(request, asked.forwarded, source);
    // The send-side monitors run here whatever the destination; made first, so that a script
    // that fails leaves nothing behind.
    auto send_chain = host_.scripts().build_chain(carrier, proto::Side::send, source, destination);
    if (!send_chain)
        co_return refuse(send_chain.error().message);

    auto local_destination = router.find(destination);
    // A network carrier named explicitly goes through the network even between ports of this
    // daemon (over loopback); only `local`, or no carrier, stays in the daemon.
    const bool wants_network = !automatic && carrier.base != "local";
    const bool wants_local = !automatic && carrier.base == "local";
    if (local_destination && !wants_network) {
        auto connection = std::make_shared<Connection>();
        connection->source = source;
        connection->destination = destination;
        connection->carrier = automatic ? "local" : carrier_text;
        connection->priority = carrier.qos.prio.value_or(0);
        const InletSpec spec{local_destination, source, carrier, connection->carrier, asked.strict};
        // The connection takes the inlet before the inlet joins its port: a pair already
        // connected is refused with nothing joined.
        const InletHandOver hand_over = [&](const std::shared_ptr<Inlet>& inlet) {
            connection->sink = inlet;
            connection->send_monitors = send_stage(host_.scripts(), std::move(*send_chain), connection);
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
    if (wants_local) {
        co_return refuse("carrier 'local' needs both ports on one daemon, and " + destination +
                         " is not on this one");
    }
    std::string where;
    if (local_destination) {
        where = host_.address();
    } else {
        auto found = co_await host_.names().lookup(destination);
        if (!found)
            co_return refuse(found.error().message);
        where = found->address;
    }
    std::string chosen = carrier_text;
    if (automatic)
        chosen = "tcp";
    std::shared_ptr<monitor::MonitorChain> chain = std::move(*send_chain);
    co_return co_await connect_remote(asked, port, chosen, where, chain);
}

Task<proto::Reply> ControlPlane::connect_remote(proto::ConnectRequest asked, std::shared_ptr<Port> port,
                                                std::string carrier, std::string address,
                                                std::shared_ptr<monitor::MonitorChain> send_chain) {
    const std::string source = port->name();
    const std::string destination = asked.destination;
    for (const auto& existing : port->outgoing) {
        if (existing->destination == destination)
            co_return refuse("ports " + source + " and " + destination + " are already connected");
    }
    auto endpoint = proto::parse_endpoint(address);
    if (!endpoint)
        co_return refuse("the name server gave a bad address for " + destination + ": " + address);
    auto end = co_await open_sending_end(port, destination, carrier, *endpoint, asked.strict);
    if (!end.peer)
        co_return end.answer;
    auto connection = std::make_shared<Connection>();
    connection->source = source;
    connection->destination = destination;
    connection->carrier = carrier;
    connection->remote = true;
    connection->priority = qos_of(carrier).prio.value_or(0);
    connection->persistent = asked.persist;
    connection->sink = end.sink;
    if (auto* mcast = dynamic_cast<carriers::McastLink*>(end.sink.get())) {
        // The send-side monitors of mcast run once per message, for the port's one sender, not
        // once per connection: all mcast connections of a port share them, on one stage.
        const auto& sender = mcast->shared_sender();
        auto first = sender->share_send_clauses(send_clauses(carrier));
        if (!first) {
            end.peer->close("send monitors differ");
            co_return refuse(first.error().message);
        }
        if (*first && send_chain) {
            monitor::MonitorStage::Options options;
            options.drop_oldest = true;  // datagrams never hold the writer back
            sender->attach_send_stage(
                host_.scripts().make_stage(std::move(send_chain), nullptr, options, sender));
        }
    } else {
        connection->send_monitors = send_stage(host_.scripts(), std::move(send_chain), connection);
    }
    if (auto added = host_.router().add(port, connection); !added) {
        end.peer->close("duplicate");
        co_return refuse(added.error().message);
    }
    host_.keep_link(end.peer);
    watch_link(end, connection);
    names::ConnectionEntry entry{source, destination, carrier, connection->persistent};
    co_await host_.names().add_connection(std::move(entry));
    spdlog::info("connected {} -> {} ({} to {})", source, destination, carrier, address);
    co_return ok(proto::ConnectReply{carrier, end.attached.warnings});
}

Task<ControlPlane::SendingEnd> ControlPlane::open_sending_end(std::shared_ptr<Port> port,
                                                              std::string destination, std::string carrier,
                                                              proto::Endpoint endpoint, bool strict) {
    const std::string source = port->name();
    SendingEnd end;
    std::string group;
    if (has_base(carrier, "mcast")) {
        // One group per source port, given out by the name server: every daemon with a reader
        // joins it, and this daemon sends each message there once.
        auto given = co_await host_.names().mcast_group(source);
        if (!given) {
            end.answer = refuse("no multicast group for " + source + ": " + given.error().message);
            co_return end;
        }
        group = *given;
    }
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
    // qos.dscp marks the link's socket: every connection has a link socket of its own, so the
    // mark is this connection's alone (udp and mcast mark their datagrams below).
    const proto::Qos qos = qos_of(carrier);
    if (qos.dscp) {
        if (auto marked = link_peer->mark_packets(*qos.dscp); !marked) {
            link_peer->close("cannot mark packets");
            end.answer = refuse(marked.error().message);
            co_return end;
        }
    }
    // The receiving daemon wires its end (monitors, arbitration) while it answers attach.
    const nlohmann::json attach_body =
        proto::AttachRequest{source, destination, carrier, strict, group}.encode();
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
    if (!group.empty()) {
        // mcast: every message goes once to the source port's group, whatever the connections.
        auto sender = host_.udp().mcast_sender(source, *group_endpoint(group));
        if (qos.dscp)
            sender->mark(*qos.dscp);
        end.peer = link_peer;
        end.sink = std::make_shared<carriers::McastLink>(std::move(sender), link_peer);
        co_return end;
    }
    if (has_base(carrier, "udp")) {
        // udp: every message leaves at once as datagrams to the stream the receiver opened; the
        // link stays open beside it, and its closing ends the connection.
        auto sink = udp_sending_end(link_peer, endpoint, *attached,
                                    "connection " + source + " -> " + destination, qos.dscp);
        if (!sink) {
            link_peer->close("bad attach answer");
            end.answer = refuse(sink.error().message);
            co_return end;
        }
        end.peer = link_peer;
        end.sink = *sink;
        co_return end;
    }
    // tcp: messages wait in the link's queue and leave on its socket. Into a latest port the link
    // keeps only the newest few and a small socket buffer, so a slow network adds little delay
    // (the kernel's buffer would otherwise hold seconds of data at 10 Mbit/s); into a strict port
    // it holds the writer back.
    const bool latest = attached->policy == "latest";
    const std::size_t capacity = latest
                                     ? std::min<std::size_t>(host_.config().link_capacity,
                                                             std::max<std::uint64_t>(1, attached->capacity))
                                     : host_.config().link_capacity;
    constexpr int latest_send_buffer = 64 * 1024;
    if (latest)
        link_peer->limit_send_buffer(latest_send_buffer);
    auto link = std::make_shared<carriers::TcpLink>(link_peer, capacity, host_.config().queue_bytes,
                                                    latest ? QueuePolicy::latest : QueuePolicy::strict);
    end.peer = link_peer;
    end.sink = link;
    end.queue = link->queue();
    co_return end;
}

void ControlPlane::watch_link(const SendingEnd& end, const std::shared_ptr<Connection>& connection) {
    std::weak_ptr<Connection> weak = connection;
    // The queue is held here, not reached through the connection: after a disconnect the
    // connection is gone while the link still drains, and what it could not send must be counted.
    end.peer->closed_handler = [&host = host_, weak, queue = end.queue, source = connection->source,
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
    const InletSpec spec{port, source, *carrier, carrier->text(), asked->strict};
    auto wired = wire_inlet(host_.scripts(), host_.clock(), spec);
    if (!wired)
        co_return refuse(wired.error().message);
    // The sending daemon shapes its end after this port's queue (a latest port gets a latest link).
    proto::AttachReply answer;
    answer.warnings = wired->warnings;
    answer.policy = queue_policy_name(port->queue().policy());
    answer.capacity = port->queue().capacity();
    if (carrier->base == "udp") {
        // udp: datagrams from the link's address, for a stream of its own, feed the inlet.
        const auto sender = session->remote_ip();
        if (!sender)
            co_return refuse("the udp carrier needs a link over TCP (an IP address to take datagrams from)");
        auto stream = host_.udp().open_stream(wired->inlet, *sender);
        wired->inlet->datagrams = UdpSocket::datagrams(*stream);
        answer.udp_port = host_.udp().port();
        answer.stream = UdpSocket::id(*stream);
        session->hold_while_linked(stream);
    }
    // tcp: the link session itself feeds the inlet, with the data frames the sending daemon writes.
    if (carrier->base == "mcast") {
        // mcast: join the source port's group, which the name server (not the sender) vouches for.
        const std::string& claimed = asked->group;
        auto given = co_await host_.names().mcast_group(source);
        if (!given)
            co_return refuse("no multicast group for " + source + ": " + given.error().message);
        const auto group = group_endpoint(*given);
        if (!group || claimed != *given)
            co_return refuse("the group " + claimed + " is not the one the name server gives " + source);
        const auto sender = session->remote_ip();
        if (!sender)
            co_return refuse("the mcast carrier needs a link over TCP");
        auto joined = host_.udp().join_group(*group, wired->inlet, *sender);
        if (!joined)
            co_return refuse(joined.error().message);
        wired->inlet->datagrams = UdpSocket::datagrams(**joined);
        session->hold_while_linked(*joined);
    }
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

Task<proto::Reply> ControlPlane::disconnect(std::shared_ptr<Session>, const proto::Request& request) {
    const auto asked = proto::DisconnectRequest::decode(request.body);
    if (!asked)
        co_return malformed(asked.error());
    const std::string source = asked->source;
    const std::string destination = asked->destination;
    if (!host_.router().find(source))
        co_return co_await forward(request, asked->forwarded, source);
    auto removed = host_.router().remove(source, destination);
    if (!removed)
        co_return refuse("ports " + source + " and " + destination + " are not connected", ReplyCode::no);
    host_.notify_space();
    co_await host_.names().remove_connection(source, destination, true);
    spdlog::info("disconnected {} -> {}", source, destination);
    co_return ok(proto::DisconnectReply{});
}

Task<void> ControlPlane::restore_persistent(std::vector<names::ConnectionEntry> persistent) {
    for (const auto& entry : persistent) {
        proto::ConnectRequest asked;
        asked.source = entry.source;
        asked.destination = entry.destination;
        asked.carrier = entry.carrier;
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
