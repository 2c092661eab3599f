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
#include "plexus/proto/datagram_seal.hpp"
#include "udp_config.hpp"

namespace plexus::daemon {

namespace carriers {
class McastSender;
}

/// Daemon-wide counters of the datagram socket (`plexus stats`, under "daemon").
struct UdpCounters {
    std::uint64_t datagrams_sent = 0;
    std::uint64_t datagrams_received = 0;
    std::uint64_t bad_datagrams = 0;   ///< malformed, or over the size limit
    std::uint64_t unknown_stream = 0;  ///< for no stream open here (a connection that went away)
    std::uint64_t wrong_sender = 0;    ///< for a stream open here, from another address
    std::uint64_t send_failures = 0;   ///< datagrams the socket would not take (buffer full)
    /// Refused by its seal (docs/SECURITY.md, "Datagrams"): not sealed on a stream that is, or its
    /// tag does not check out (altered, forged, or sealed under a key of before a restart).
    std::uint64_t bad_mac = 0;
};

/// What one udp sending end reports (`plexus stats`, on the connection).
struct UdpSendCounters {
    std::uint64_t messages = 0;  ///< sent whole
    std::uint64_t datagrams = 0;
    std::uint64_t dropped_too_large = 0;  ///< larger than max_message: never sent
    std::uint64_t dropped_send = 0;       ///< not all of its datagrams left (socket buffer full)
};

/// The datagram machinery that the udp and mcast carriers (carriers/udp.hpp, carriers/mcast.hpp)
/// share: the daemon's UDP socket, bound to the address and port number of its TCP listener, sends
/// the datagrams of udp and mcast connections out of this daemon's ports and takes those of udp
/// connections into them; one more socket per multicast group that a connection into a port here
/// listens to. Datagrams are only accepted for a stream opened by an `attach` on a TCP
/// link, only from that link's address, only with records of the attached source, and, with the
/// deployment secret, only sealed under the stream's key (proto/datagram_seal.hpp).
class UdpSocket {
public:
    /// What an mcast stream of a source port here is sealed with, and the number of its next message:
    /// kept for the daemon's life, not the sending end's, so that a sending end made again for the
    /// port goes on numbering and never seals two messages under one nonce.
    struct McastStream {
        explicit McastStream(const proto::DatagramKey& key) : seal(key) {}
        proto::DatagramSeal seal;
        std::uint64_t next_message = 0;
    };

    UdpSocket(asio::io_context& io, UdpConfig config, std::optional<proto::Secret> secret = {});
    ~UdpSocket();
    UdpSocket(const UdpSocket&) = delete;
    UdpSocket& operator=(const UdpSocket&) = delete;

    proto::Status bind(const asio::ip::address& address, std::uint16_t port);
    void start();
    void stop();
    std::uint16_t port() const;
    const UdpConfig& config() const { return config_; }
    const UdpCounters& counters() const { return counters_; }
    const ReassemblyBudget& budget() const { return *budget_; }
    /// True with the deployment secret: every stream's datagrams are sealed.
    bool sealing() const { return secret_.has_value(); }

    /// Opens a receiving stream for a connection into `inlet` whose datagrams come from `sender`;
    /// when sealing, with a new random key (key()) for the sender. The stream is closed when the
    /// returned handle is dropped.
    struct Stream;
    std::shared_ptr<Stream> open_stream(std::weak_ptr<Inlet> inlet, asio::ip::address sender);
    /// Joins multicast `group` (once per group, however many connections listen to it) for a
    /// connection into `inlet` whose source's daemon at `sender` sends there, sealed under `key`
    /// (when sealing: the sender's key from its attach), from message `first_message` on (the
    /// sender's next number then: nothing older starts the stream). The group is left when the last
    /// handle is dropped.
    proto::Result<std::shared_ptr<Stream>> join_group(const asio::ip::udp::endpoint& group,
                                                      std::weak_ptr<Inlet> inlet, asio::ip::address sender,
                                                      std::optional<proto::DatagramKey> key,
                                                      std::uint64_t first_message = 0);
    static std::uint64_t id(const Stream& stream);
    /// The key the stream's datagrams are sealed with; nullopt when not sealing.
    static std::optional<proto::DatagramKey> key(const Stream& stream);
    /// The sealed mcast stream of source port `source` here, made (with a new random key) the first
    /// time it is asked for.
    McastStream& mcast_stream(const std::string& source);
    static std::shared_ptr<const DatagramStream> datagrams(const Stream& stream);

    /// Sends one record to `to` as message `message` of `stream`, cut into datagrams (each sealed
    /// by `seal` when given), each marked with `marks` when given (`qos.dscp`). False if the
    /// socket did not take all of them (the receiver will count the message lost).
    bool send(const asio::ip::udp::endpoint& to, std::uint64_t stream, std::uint64_t message,
              proto::ByteView record, DatagramMarks* marks = nullptr, proto::DatagramSeal* seal = nullptr);
    /// send() with the bookkeeping of a sending end: a record over max_message is dropped (logged
    /// the first time), else numbered `next_message` (then advanced) and counted.
    void send_counted(const asio::ip::udp::endpoint& to, std::uint64_t stream, std::uint64_t& next_message,
                      proto::ByteView record, UdpSendCounters& counters, const std::string& description,
                      DatagramMarks* marks = nullptr, proto::DatagramSeal* seal = nullptr);
    /// Marks for the datagrams of a connection that asked for `qos.dscp.N`, fit for this socket.
    DatagramMarks marks_for(int dscp) const;
    /// The multicast sending end of a source port, shared by all of its mcast connections. Found
    /// here, beside the one socket it sends on, because the carriers themselves are stateless
    /// entries of a table (carriers/carrier_table.hpp).
    std::shared_ptr<carriers::McastSender> mcast_sender(const std::string& source,
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
    std::map<std::string, std::weak_ptr<Group>> groups_;                   ///< by "group:port"
    std::map<std::string, std::weak_ptr<carriers::McastSender>> senders_;  ///< by source port
    std::map<std::string, std::unique_ptr<McastStream>> mcast_streams_;    ///< by source port
    std::shared_ptr<ReassemblyBudget> budget_;
    std::map<std::uint64_t, std::weak_ptr<Stream>> streams_;
    std::uint64_t next_stream_ = 1;
    UdpCounters counters_;
    bool stopped_ = false;
    bool priority_refused_ = false;  ///< this kernel takes no SO_PRIORITY as ancillary data
};

}  // namespace plexus::daemon
