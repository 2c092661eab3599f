#pragma once
// Threading: one io_context thread.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "../../core/connection.hpp"
#include "../asio.hpp"
#include "../packet_marks.hpp"
#include "../peer.hpp"
#include "../udp_socket.hpp"
#include "carrier.hpp"

namespace plexus::daemon::carriers {

/// The sending end of a udp connection: every record goes out at once as datagrams, best effort.
/// Never full, so it never holds a writer back. The TCP link to the receiving daemon stays open
/// beside it: it carried the attach, and its closing ends the connection.
class UdpLink : public MessageSink {
public:
    UdpLink(UdpSocket& socket, asio::ip::udp::endpoint to, std::uint64_t stream,
            std::shared_ptr<Peer> control, std::string description, std::optional<int> dscp = {},
            std::optional<proto::DatagramKey> key = {})
        : socket_(socket),
          to_(std::move(to)),
          stream_(stream),
          control_(std::move(control)),
          description_(std::move(description)) {
        if (dscp)
            marks_ = socket_.marks_for(*dscp);
        if (key)
            seal_ = std::make_unique<proto::DatagramSeal>(*key);
    }
    bool full() const override { return false; }
    std::size_t room() const override { return never_full_room; }
    void deliver(const Message& message) override;
    void close_after_flush() override { control_->close_when_drained(); }
    void report_stats(nlohmann::json& entry) const override;
    const UdpSendCounters& counters() const { return counters_; }

private:
    UdpSocket& socket_;
    asio::ip::udp::endpoint to_;
    std::uint64_t stream_;
    std::shared_ptr<Peer> control_;  ///< the TCP link that attached the connection
    std::string description_;
    std::uint64_t next_message_ = 0;
    UdpSendCounters counters_;
    std::optional<DatagramMarks> marks_;         ///< qos.dscp: the shared socket marks each datagram
    std::unique_ptr<proto::DatagramSeal> seal_;  ///< with a secret: the key the receiver gave
};

/// udp: best effort, every message at once as datagrams on the daemon's UDP socket; losses are
/// counted at the receiver from sequence gaps. The receiving daemon opens a stream of its own for
/// the connection, fed only by datagrams from the link's address; the link stays open beside it.
class UdpCarrier final : public Carrier {
public:
    std::string_view name() const override { return "udp"; }
    proto::Result<SendingEnd> make_sending_end(const SendingContext& context) const override;
    Task<proto::Result<proto::AttachReply>> attach_receiving_end(ReceivingContext context,
                                                                 proto::AttachReply answer) const override;
};

}  // namespace plexus::daemon::carriers
