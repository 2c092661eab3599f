// The udp carrier (udp.hpp).
#include "udp.hpp"

#include <nlohmann/json.hpp>

#include "../../core/batch.hpp"

namespace plexus::daemon::carriers {

void UdpLink::deliver(const Message& message) {
    for_each_record(message, [this](const Message& single) {
        socket_.send_counted(to_, stream_, next_message_, single.record, counters_, description_,
                             marks_ ? &*marks_ : nullptr, seal_.get());
    });
}

void UdpLink::report_stats(nlohmann::json& entry) const {
    entry["udp"] = {{"messages", counters_.messages},
                    {"datagrams", counters_.datagrams},
                    {"dropped_too_large", counters_.dropped_too_large},
                    {"dropped_send", counters_.dropped_send}};
}

proto::Result<SendingEnd> UdpCarrier::make_sending_end(const SendingContext& context) const {
    // Datagrams go to the stream the receiving daemon opened in its answer to attach.
    const std::uint64_t port = context.attached.udp_port.value_or(0);
    const std::uint64_t stream = context.attached.stream;
    boost::system::error_code ec;
    const auto address = asio::ip::make_address(context.endpoint.host, ec);
    if (port == 0 || port > 65535 || stream == 0 || ec) {
        return proto::Error{
            "the daemon at " + context.endpoint.text() +
            " gave no usable udp port and stream for this connection (udp needs IP addresses)"};
    }
    std::optional<proto::DatagramKey> key;
    if (context.host.udp().sealing()) {
        auto given = proto::parse_key_text(context.attached.key);
        if (!given)
            return proto::Error{
                "the daemon at " + context.endpoint.text() +
                " gave no usable key for this udp stream's sealed datagrams: " + given.error().message};
        key = *given;
    }
    const asio::ip::udp::endpoint to(address, static_cast<std::uint16_t>(port));
    auto link = std::make_shared<UdpLink>(
        context.host.udp(), to, stream, context.link,
        "connection " + context.request.source + " -> " + context.request.destination,
        context.carrier.qos.dscp, key);
    SendingEnd end;
    end.sink = link;
    end.send_monitors = own_send_monitors(context, *link);
    return end;
}

Task<proto::Result<proto::AttachReply>> UdpCarrier::attach_receiving_end(ReceivingContext context,
                                                                         proto::AttachReply answer) const {
    // Datagrams from the link's address, for a stream of its own, feed the inlet; the stream lives
    // as long as the link.
    const auto sender = context.session->remote_ip();
    if (!sender)
        co_return proto::Error{
            "the udp carrier needs a link over TCP (an IP address to take datagrams from)"};
    UdpSocket& socket = context.host.udp();
    auto stream = socket.open_stream(context.inlet, *sender);
    context.inlet->datagrams = UdpSocket::datagrams(*stream);
    answer.udp_port = socket.port();
    answer.stream = UdpSocket::id(*stream);
    if (const auto key = UdpSocket::key(*stream))
        answer.key = proto::key_text(*key);  // inside the TLS link: only the sender learns it
    context.session->hold_while_linked(stream);
    co_return answer;
}

}  // namespace plexus::daemon::carriers
