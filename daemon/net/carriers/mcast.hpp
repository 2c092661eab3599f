#pragma once
// Threading: one io_context thread.

#include <memory>

#include <nlohmann/json_fwd.hpp>

#include "../../core/connection.hpp"
#include "../peer.hpp"
#include "carrier.hpp"
#include "mcast_sender.hpp"

namespace plexus::daemon::carriers {

/// The sending end of one mcast connection: hands every message to its port's McastSender. Like
/// a udp connection it is never full, and the TCP link that attached it stays open beside it.
class McastLink : public MessageSink {
public:
    McastLink(std::shared_ptr<McastSender> sender, std::shared_ptr<Peer> control)
        : sender_(std::move(sender)), control_(std::move(control)) {}
    bool full() const override { return false; }
    std::size_t room() const override { return never_full_room; }
    void deliver(const Message& message) override { sender_->deliver(message); }
    void close_after_flush() override { control_->close_when_drained(); }
    /// The port's one sender: every mcast connection of the port shows the same counters.
    void report_stats(nlohmann::json& entry) const override;
    /// The port's send-side monitors, which every mcast connection of the port shares.
    std::shared_ptr<MessageFilter> shared_send_stage() const override { return sender_->send_stage(); }
    const McastSender& sender() const { return *sender_; }
    const std::shared_ptr<McastSender>& shared_sender() const { return sender_; }

private:
    std::shared_ptr<McastSender> sender_;
    std::shared_ptr<Peer> control_;
};

/// mcast: best effort, each message of a source port sent once to the port's multicast group,
/// whatever the number of receiving daemons. The name server gives each source port its group;
/// every receiving daemon checks the group with it and joins. All mcast connections of a port
/// share one sender (McastSender) and so its send-side monitors.
class McastCarrier final : public Carrier {
public:
    std::string_view name() const override { return "mcast"; }
    Task<proto::Result<proto::AttachRequest>> prepare_attach(CarrierHost& host,
                                                             proto::AttachRequest request) const override;
    proto::Result<SendingEnd> make_sending_end(const SendingContext& context) const override;
    Task<proto::Result<proto::AttachReply>> attach_receiving_end(ReceivingContext context,
                                                                 proto::AttachReply answer) const override;
};

}  // namespace plexus::daemon::carriers
