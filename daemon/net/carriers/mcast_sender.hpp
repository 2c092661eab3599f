#pragma once
// Threading: the daemon's one thread; the send-side monitors it runs for its port are on a stage
// of their own (a worker), and their verdicts come back here (filtered()).

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "../../core/message.hpp"
#include "../../core/message_filter.hpp"
#include "../asio.hpp"
#include "../packet_marks.hpp"
#include "../udp_socket.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::daemon::carriers {

/// What the multicast sending end of a source port reports (`plexus stats`, on the port):
/// `messages` were sent once each, whatever the number of receiving daemons.
struct McastSendCounters : UdpSendCounters {
    std::uint64_t dropped_by_monitor = 0;  ///< dropped by the shared send-side monitors
};

/// The multicast sending end of one source port: every message goes out once, to the port's
/// group, however many mcast connections (to however many daemons) the port has. Each of those
/// connections hands it every message; it sends the first hand-over of each and skips the rest.
class McastSender final : public FilterClient {
public:
    McastSender(UdpSocket& socket, asio::ip::udp::endpoint group, std::string source)
        : socket_(socket),
          group_(std::move(group)),
          source_(std::move(source)),
          stream_(socket.mcast_stream(source_)) {}
    ~McastSender() override;
    void deliver(const Message& message);
    void filtered(std::vector<Filtered>& results) override;
    const McastSendCounters& counters() const { return counters_; }
    const asio::ip::udp::endpoint& group() const { return group_; }
    /// The send-side monitors run once per message before it goes to the group, so every mcast
    /// connection of the port must ask for the same ones (`clauses`, their carrier text, "" for
    /// none). True for the first connection: it brings them (attach_send_stage); false for a later
    /// one asking for the same (its own monitors are let go); an Error for different clauses.
    proto::Result<bool> share_send_clauses(const std::string& clauses);
    /// The stage of the monitors the first connection brought (see share_send_clauses).
    void attach_send_stage(std::shared_ptr<MessageFilter> stage) { stage_ = std::move(stage); }
    const std::shared_ptr<MessageFilter>& send_stage() const { return stage_; }
    /// A connection of the port asks for `qos.dscp.N`. Its messages are the port's, sent once for
    /// all connections, so they carry the highest DSCP any connection asked for: the one that
    /// asked for most gets it, the others get more than they asked, never less.
    void mark(int dscp);

private:
    void send(const Message& message);

    UdpSocket& socket_;
    asio::ip::udp::endpoint group_;
    std::string source_;
    UdpSocket::McastStream& stream_;  ///< the port's numbering and key, which outlive this sender
    /// The last unit sent, held so that its storage (and so its address) cannot be reused by a
    /// later message while it is compared against.
    Message last_;
    McastSendCounters counters_;
    std::optional<std::string> clauses_;  ///< set by the first connection
    std::shared_ptr<MessageFilter> stage_;
    std::optional<int> dscp_;
    std::optional<DatagramMarks> marks_;
};

}  // namespace plexus::daemon::carriers
