// The mcast carrier (mcast.hpp).
#include "mcast.hpp"

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "plexus/proto/endpoint.hpp"

namespace plexus::daemon::carriers {

namespace {

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

/// The send-side clauses of a carrier, as text ("" when none): what mcast connections of one port
/// must agree on.
std::string send_clauses(const proto::Carrier& carrier) {
    proto::Carrier sends;
    sends.base = carrier.base;
    for (const auto& clause : carrier.clauses) {
        if (clause.side == proto::Side::send)
            sends.clauses.push_back(clause);
    }
    return sends.clauses.empty() ? std::string{} : sends.text();
}

}  // namespace

void McastLink::report_stats(nlohmann::json& entry) const {
    const auto& sent = sender_->counters();
    const auto& group = sender_->group();
    entry["mcast"] = {{"group", group.address().to_string() + ":" + std::to_string(group.port())},
                      {"messages_sent_once", sent.messages},
                      {"datagrams", sent.datagrams},
                      {"dropped_too_large", sent.dropped_too_large},
                      {"dropped_send", sent.dropped_send},
                      {"dropped_by_monitor", sent.dropped_by_monitor}};
}

Task<proto::Result<proto::AttachRequest>> McastCarrier::prepare_attach(CarrierHost& host,
                                                                       proto::AttachRequest request) const {
    // One group per source port, given out by the name server: every daemon with a reader joins
    // it, and this daemon sends each message there once.
    auto given = co_await host.mcast_group(request.source);
    if (!given)
        co_return proto::Error{"no multicast group for " + request.source + ": " + given.error().message};
    request.group = *given;
    auto& stream = host.udp().mcast_stream(request.source);
    if (host.udp().sealing())  // inside the TLS link: only the receiving daemons learn it
        request.key = proto::key_text(stream.seal.key());
    request.first_message = stream.next_message;
    co_return request;
}

proto::Result<SendingEnd> McastCarrier::make_sending_end(const SendingContext& context) const {
    const auto group = group_endpoint(context.request.group);
    if (!group)
        return proto::Error{"the name server gave " + context.request.source + " no multicast group: '" +
                            context.request.group + "'"};
    auto sender = context.host.udp().mcast_sender(context.request.source, *group);
    if (context.carrier.qos.dscp)
        sender->mark(*context.carrier.qos.dscp);
    // The send-side monitors run once per message, for the port's one sender, not once per
    // connection: all mcast connections of a port share them, on one stage. The first connection
    // brings them; a later one asking for the same lets its own go.
    auto first = sender->share_send_clauses(send_clauses(context.carrier));
    if (!first)
        return first.error();
    if (*first && context.make_send_stage) {
        if (auto stage = context.make_send_stage(sender, /*drop_oldest=*/true))  // datagrams never hold back
            sender->attach_send_stage(std::move(stage));
    }
    SendingEnd end;
    end.sink = std::make_shared<McastLink>(std::move(sender), context.link);
    return end;
}

Task<proto::Result<proto::AttachReply>> McastCarrier::attach_receiving_end(ReceivingContext context,
                                                                           proto::AttachReply answer) const {
    // Join the source port's group, which the name server (not the sender) vouches for.
    const std::string& source = context.request.source;
    const std::string& claimed = context.request.group;
    auto given = co_await context.host.mcast_group(source);
    if (!given)
        co_return proto::Error{"no multicast group for " + source + ": " + given.error().message};
    const auto group = group_endpoint(*given);
    if (!group || claimed != *given)
        co_return proto::Error{"the group " + claimed + " is not the one the name server gives " + source};
    const auto sender = context.session->remote_ip();
    if (!sender)
        co_return proto::Error{"the mcast carrier needs a link over TCP"};
    std::optional<proto::DatagramKey> key;
    if (!context.request.key.empty()) {
        auto given = proto::parse_key_text(context.request.key);
        if (!given)
            co_return proto::Error{"the key of " + source + "'s mcast stream: " + given.error().message};
        key = *given;
    }
    auto joined =
        context.host.udp().join_group(*group, context.inlet, *sender, key, context.request.first_message);
    if (!joined)
        co_return joined.error();
    context.inlet->datagrams = UdpSocket::datagrams(**joined);
    context.session->hold_while_linked(*joined);
    co_return answer;
}

}  // namespace plexus::daemon::carriers
