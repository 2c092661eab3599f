#pragma once
// Threading: one io_context thread.

#include <cstdint>
#include <map>
#include <memory>

#include "../core/inlet.hpp"
#include "../core/reassembly.hpp"
#include "asio.hpp"
#include "peer.hpp"
#include "plexus/proto/bytes.hpp"
#include "udp_config.hpp"

namespace plexus::daemon {

/// Daemon-wide counters of the carrier (`plexus stats`, under "daemon").
struct UdpCounters {
    std::uint64_t datagrams_sent = 0;
    std::uint64_t datagrams_received = 0;
    std::uint64_t bad_datagrams = 0;   ///< malformed, or over the size limit
    std::uint64_t unknown_stream = 0;  ///< for no stream open here (a connection that went away)
    std::uint64_t wrong_sender = 0;    ///< for a stream open here, from another address
    std::uint64_t send_failures = 0;   ///< datagrams the socket would not take (buffer full)
};

/// What one udp sending end reports (`plexus stats`, on the connection).
struct UdpSendCounters {
    std::uint64_t messages = 0;  ///< sent whole
    std::uint64_t datagrams = 0;
    std::uint64_t dropped_too_large = 0;  ///< larger than max_message: never sent
    std::uint64_t dropped_send = 0;       ///< not all of its datagrams left (socket buffer full)
};

/// The daemon's UDP socket for the udp carrier, bound to the address and port number of its TCP
/// listener: it sends the datagrams of connections out of this daemon's ports and takes those of
/// connections into them. Datagrams are only accepted for a stream opened by an `attach` on a
/// TCP link, and only from that link's address.
class UdpCarrier {
public:
    UdpCarrier(asio::io_context& io, UdpConfig config);
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
    static std::uint64_t id(const Stream& stream);
    static std::shared_ptr<const DatagramStream> datagrams(const Stream& stream);

    /// Sends one record to `to` as message `message` of `stream`, cut into datagrams. False if the
    /// socket did not take all of them (the receiver will count the message lost).
    bool send(const asio::ip::udp::endpoint& to, std::uint64_t stream, std::uint64_t message,
              proto::ByteView record);

private:
    Task<void> receive_loop();
    Task<void> expire_loop();
    void take(proto::ByteView datagram, const asio::ip::udp::endpoint& from);

    asio::io_context& io_;
    UdpConfig config_;
    asio::ip::udp::socket socket_;
    std::shared_ptr<ReassemblyBudget> budget_;
    std::map<std::uint64_t, std::weak_ptr<Stream>> streams_;
    std::uint64_t next_stream_ = 1;
    UdpCounters counters_;
    bool stopped_ = false;
};

/// The sending end of a udp connection: every record goes out at once as datagrams, best effort.
/// Never full, so it never holds a writer back. The TCP link to the receiving daemon stays open
/// beside it: it carried the attach, and its closing ends the connection.
class UdpLink : public MessageSink {
public:
    UdpLink(UdpCarrier& carrier, asio::ip::udp::endpoint to, std::uint64_t stream,
            std::shared_ptr<Peer> control, std::string description)
        : carrier_(carrier),
          to_(std::move(to)),
          stream_(stream),
          control_(std::move(control)),
          description_(std::move(description)) {}
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
};

}  // namespace plexus::daemon
