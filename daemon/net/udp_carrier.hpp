#pragma once
// Threading: one io_context thread.

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "../core/inlet.hpp"
#include "../core/message_filter.hpp"
#include "../core/reassembly.hpp"
#include "asio.hpp"
#include "packet_marks.hpp"
#include "peer.hpp"
#include "plexus/proto/auth.hpp"
#include "plexus/proto/bytes.hpp"
#include "udp_config.hpp"

namespace plexus::daemon {

class McastSender;

/// Daemon-wide counters of the carrier (`plexus stats`, under "daemon").
struct UdpCounters {
    std::uint64_t datagrams_sent = 0;
    std::uint64_t datagrams_received = 0;
    std::uint64_t bad_datagrams = 0;   ///< malformed, or over the size limit
    std::uint64_t unknown_stream = 0;  ///< for no stream open here (a connection that went away)
    std::uint64_t wrong_sender = 0;    ///< for a stream open here, from another address
    std::uint64_t send_failures = 0;   ///< datagrams the socket would not take (buffer full)
    std::uint64_t bad_mac = 0;         ///< without the MAC the deployment secret calls for, or a wrong one
};

/// What one udp sending end reports (`plexus stats`, on the connection).
struct UdpSendCounters {
    std::uint64_t messages = 0;  ///< sent whole
    std::uint64_t datagrams = 0;
    std::uint64_t dropped_too_large = 0;  ///< larger than max_message: never sent
    std::uint64_t dropped_send = 0;       ///< not all of its datagrams left (socket buffer full)
};

/// The daemon's datagram carriers. Its UDP socket, bound to the address and port number of its
/// TCP listener, sends the datagrams of udp connections out of this daemon's ports and takes those
/// of udp connections into them; one more socket per multicast group that a connection into a
/// port here listens to. Datagrams are only accepted for a stream opened by an `attach` on a TCP
/// link, only from that link's address, only with records of the attached source, and, with the
/// deployment secret, only with a good MAC.
class UdpCarrier {
public:
    UdpCarrier(asio::io_context& io, UdpConfig config, std::optional<proto::Secret> secret = {});
    ~UdpCarrier();
    UdpCarrier(const UdpCarrier&) = delete;
    UdpCarrier& operator=(const UdpCarrier&) = delete;

    proto::Status bind(const asio::ip::address& address, std::uint16_t port);
    void start();
    void stop();
    std::uint16_t port() const;
    const UdpConfig& config() const { return config_; }
    const UdpCounters& counters() const { return counters_; }
    const ReassemblyBudget& budget() const { return *budget_; }

    /// Opens a receiving stream for a connection into `inlet` whose datagrams come from `sender`.
    /// The stream is closed when the returned handle is dropped.
    struct Stream;
    std::shared_ptr<Stream> open_stream(std::weak_ptr<Inlet> inlet, asio::ip::address sender);
    /// Joins multicast `group` (once per group, however many connections listen to it) for a
    /// connection into `inlet` whose source's daemon at `sender` sends there. The group is left
    /// when the last handle is dropped.
    proto::Result<std::shared_ptr<Stream>> join_group(const asio::ip::udp::endpoint& group,
                                                      std::weak_ptr<Inlet> inlet, asio::ip::address sender);
    static std::uint64_t id(const Stream& stream);
    static std::shared_ptr<const DatagramStream> datagrams(const Stream& stream);

    /// Sends one record to `to` as message `message` of `stream`, cut into datagrams (each with a
    /// MAC when there is a secret), each marked with `marks` when given (`qos.dscp`). False if the
    /// socket did not take all of them (the receiver will count the message lost).
    bool send(const asio::ip::udp::endpoint& to, std::uint64_t stream, std::uint64_t message,
              proto::ByteView record, DatagramMarks* marks = nullptr);
    /// send() with the bookkeeping of a sending end: a record over max_message is dropped (logged
    /// the first time), else numbered `next_message` (then advanced) and counted.
    void send_counted(const asio::ip::udp::endpoint& to, std::uint64_t stream, std::uint64_t& next_message,
                      proto::ByteView record, UdpSendCounters& counters, const std::string& description,
                      DatagramMarks* marks = nullptr);
    /// Marks for the datagrams of a connection that asked for `qos.dscp.N`, fit for this socket.
    DatagramMarks marks_for(int dscp) const;
    /// The multicast sending end of a source port, shared by all of its mcast connections.
    std::shared_ptr<McastSender> mcast_sender(const std::string& source,
                                              const asio::ip::udp::endpoint& group);

private:
    struct Group;
    Task<void> receive_loop();
    Task<void> group_loop(std::shared_ptr<Group> group);
    Task<void> expire_loop();
    /// Drains what waits on `socket`, handing each datagram to take().
    void drain(asio::ip::udp::socket& socket, Stream* fixed);
    /// One datagram: on the daemon's socket `fixed` is null and the header names the stream; on a
    /// group's socket the group is the stream.
    void take(proto::ByteView datagram, const asio::ip::udp::endpoint& from, Stream* fixed);

    asio::io_context& io_;
    UdpConfig config_;
    std::optional<proto::Secret> secret_;
    asio::ip::udp::socket socket_;
    asio::ip::address interface_;  ///< the listening address: multicast leaves and is joined there
    std::map<std::string, std::weak_ptr<Group>> groups_;         ///< by "group:port"
    std::map<std::string, std::weak_ptr<McastSender>> senders_;  ///< by source port
    std::shared_ptr<ReassemblyBudget> budget_;
    std::map<std::uint64_t, std::weak_ptr<Stream>> streams_;
    std::uint64_t next_stream_ = 1;
    UdpCounters counters_;
    bool stopped_ = false;
    bool priority_refused_ = false;  ///< this kernel takes no SO_PRIORITY as ancillary data
};

/// The sending end of a udp connection: every record goes out at once as datagrams, best effort.
/// Never full, so it never holds a writer back. The TCP link to the receiving daemon stays open
/// beside it: it carried the attach, and its closing ends the connection.
class UdpLink : public MessageSink {
public:
    UdpLink(UdpCarrier& carrier, asio::ip::udp::endpoint to, std::uint64_t stream,
            std::shared_ptr<Peer> control, std::string description, std::optional<int> dscp = {})
        : carrier_(carrier),
          to_(std::move(to)),
          stream_(stream),
          control_(std::move(control)),
          description_(std::move(description)) {
        if (dscp)
            marks_ = carrier_.marks_for(*dscp);
    }
    bool full() const override { return false; }
    std::size_t room() const override { return std::size_t{1} << 30; }
    void deliver(const Message& message) override;
    void close_after_flush() override { control_->close_when_drained(); }
    const UdpSendCounters& counters() const { return counters_; }

private:
    UdpCarrier& carrier_;
    asio::ip::udp::endpoint to_;
    std::uint64_t stream_;
    std::shared_ptr<Peer> control_;  ///< the TCP link that attached the connection
    std::string description_;
    std::uint64_t next_message_ = 0;
    UdpSendCounters counters_;
    std::optional<DatagramMarks> marks_;  ///< qos.dscp: the shared socket marks each datagram
};

/// What the multicast sending end of a source port reports (`plexus stats`, on the port):
/// `messages` were sent once each, whatever the number of receiving daemons.
struct McastSendCounters : UdpSendCounters {
    std::uint64_t dropped_by_monitor = 0;  ///< dropped by the shared send-side monitors
};

/// The multicast sending end of one source port: every message goes out once, to the port's
/// group, however many mcast connections (to however many daemons) the port has. Each of those
/// connections hands it every message; it sends the first hand-over of each and skips the rest.
/// Threading: the daemon's thread; its send-side monitors run on their own stage (a worker), as a
/// connection's do, and their verdicts come back here (filtered()).
class McastSender final : public FilterClient {
public:
    McastSender(UdpCarrier& carrier, asio::ip::udp::endpoint group, std::string source)
        : carrier_(carrier), group_(std::move(group)), source_(std::move(source)) {}
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

    UdpCarrier& carrier_;
    asio::ip::udp::endpoint group_;
    std::string source_;
    std::uint64_t next_message_ = 0;
    /// The last unit sent, held so that its storage (and so its address) cannot be reused by a
    /// later message while it is compared against.
    Message last_;
    McastSendCounters counters_;
    std::optional<std::string> clauses_;  ///< set by the first connection
    std::shared_ptr<MessageFilter> stage_;
    std::optional<int> dscp_;
    std::optional<DatagramMarks> marks_;
};

/// The sending end of one mcast connection: hands every message to its port's McastSender. Like
/// a udp connection it is never full, and the TCP link that attached it stays open beside it.
class McastLink : public MessageSink {
public:
    McastLink(std::shared_ptr<McastSender> sender, std::shared_ptr<Peer> control)
        : sender_(std::move(sender)), control_(std::move(control)) {}
    bool full() const override { return false; }
    std::size_t room() const override { return std::size_t{1} << 30; }
    void deliver(const Message& message) override { sender_->deliver(message); }
    void close_after_flush() override { control_->close_when_drained(); }
    const McastSender& sender() const { return *sender_; }
    const std::shared_ptr<McastSender>& shared_sender() const { return sender_; }

private:
    std::shared_ptr<McastSender> sender_;
    std::shared_ptr<Peer> control_;
};

}  // namespace plexus::daemon
