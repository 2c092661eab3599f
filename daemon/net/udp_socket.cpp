#include "udp_socket.hpp"

#include <sys/socket.h>

#include <algorithm>
#include <array>
#include <cerrno>

#include <spdlog/spdlog.h>

#include "carriers/mcast_sender.hpp"
#include "plexus/proto/datagram.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::daemon {

namespace {
constexpr std::size_t largest_datagram = 65535;
/// Datagrams handed to the kernel in one sendmmsg call.
constexpr std::size_t datagrams_per_call = 64;
/// Socket buffers: a 1 MiB message is ~750 datagrams leaving at once, and a receiver that falls
/// behind for a moment should not lose what the kernel could have held.
constexpr int socket_buffer_bytes = 8 * 1024 * 1024;
}  // namespace

struct UdpSocket::Group {
    explicit Group(asio::io_context& io) : socket(io) {}
    asio::ip::udp::socket socket;
    std::weak_ptr<Stream> stream;
    std::string key;
};

struct UdpSocket::Stream {
    std::uint64_t id = 0;                      ///< 0 for a multicast group's stream
    std::vector<std::weak_ptr<Inlet>> inlets;  ///< one for udp; every connection of the group for mcast
    asio::ip::address sender;
    std::shared_ptr<DatagramStream> datagrams;
    std::unique_ptr<proto::DatagramSeal> seal;  ///< when sealing: the key its datagrams are sealed with
    UdpSocket* owner = nullptr;                 ///< null once the socket is gone
    std::shared_ptr<Group> group;               ///< mcast: the joined group, left with the last handle
    ~Stream() {
        if (owner && id != 0)
            owner->streams_.erase(id);
        if (group) {
            boost::system::error_code ignored;
            group->socket.close(ignored);  // ends its loop; closing leaves the group
        }
    }
};

UdpSocket::UdpSocket(asio::io_context& io, UdpConfig config, std::optional<proto::Secret> secret)
    : io_(io),
      config_(config),
      secret_(std::move(secret)),
      socket_(io),
      budget_(std::make_shared<ReassemblyBudget>()) {
    budget_->max_bytes = config_.reassembly_bytes;
}

UdpSocket::~UdpSocket() {
    // Streams may outlive the socket in sessions still being torn down: they must not reach back.
    for (auto& [id, weak] : streams_) {
        if (auto stream = weak.lock())
            stream->owner = nullptr;
    }
    for (auto& [key, weak] : groups_) {
        if (auto group = weak.lock()) {
            if (auto stream = group->stream.lock())
                stream->owner = nullptr;
        }
    }
}

proto::Status UdpSocket::bind(const asio::ip::address& address, std::uint16_t port) {
    boost::system::error_code ec;
    const asio::ip::udp::endpoint endpoint(address, port);
    socket_.open(endpoint.protocol(), ec);
    if (!ec)
        socket_.bind(endpoint, ec);
    if (ec) {
        return proto::Error{"cannot listen on UDP " + address.to_string() + ":" + std::to_string(port) +
                            " (the udp carrier uses the TCP port's number): " + ec.message()};
    }
    interface_ = address;
    socket_.non_blocking(true, ec);
    // Multicast leaves by the listening address's interface, and goes as far as configured.
    if (address.is_v4() && !address.is_unspecified())
        socket_.set_option(asio::ip::multicast::outbound_interface(address.to_v4()), ec);
    socket_.set_option(asio::ip::multicast::hops(config_.mcast_ttl), ec);
    socket_.set_option(asio::ip::multicast::enable_loopback(true), ec);
    socket_.set_option(asio::socket_base::send_buffer_size(socket_buffer_bytes), ec);
    socket_.set_option(asio::socket_base::receive_buffer_size(socket_buffer_bytes), ec);
    return proto::Ok{};
}

void UdpSocket::start() {
    asio::co_spawn(io_, receive_loop(), asio::detached);
    asio::co_spawn(io_, expire_loop(), asio::detached);
}

void UdpSocket::stop() {
    stopped_ = true;
    boost::system::error_code ignored;
    socket_.close(ignored);
    for (auto& [key, weak] : groups_) {
        if (auto group = weak.lock())
            group->socket.close(ignored);
    }
}

std::uint16_t UdpSocket::port() const {
    boost::system::error_code ec;
    const auto local = socket_.local_endpoint(ec);
    return ec ? 0 : local.port();
}

std::shared_ptr<UdpSocket::Stream> UdpSocket::open_stream(std::weak_ptr<Inlet> inlet,
                                                          asio::ip::address sender) {
    auto stream = std::make_shared<Stream>();
    stream->id = next_stream_++;
    stream->inlets.push_back(std::move(inlet));
    stream->sender = std::move(sender);
    if (sealing())
        stream->seal = std::make_unique<proto::DatagramSeal>(proto::random_datagram_key());
    DatagramStream::Limits limits;
    limits.timeout = config_.reassembly_timeout;
    stream->datagrams = std::make_shared<DatagramStream>(budget_, limits);
    stream->owner = this;
    streams_[stream->id] = stream;
    return stream;
}

proto::Result<std::shared_ptr<UdpSocket::Stream>> UdpSocket::join_group(
    const asio::ip::udp::endpoint& group, std::weak_ptr<Inlet> inlet, asio::ip::address sender,
    std::optional<proto::DatagramKey> seal_key, std::uint64_t first_message) {
    using Outcome = proto::Result<std::shared_ptr<Stream>>;
    if (sealing() != seal_key.has_value()) {
        return Outcome(proto::Error{sealing() ? "the sending daemon gave no key for its sealed mcast stream"
                                              : "a key for an mcast stream, but this daemon has no secret"});
    }
    const std::string key = group.address().to_string() + ":" + std::to_string(group.port());
    if (auto known = groups_.find(key); known != groups_.end()) {
        if (auto joined = known->second.lock()) {
            if (auto stream = joined->stream.lock()) {
                if (stream->sender != sender)
                    return Outcome(proto::Error{"group " + key + " is already fed by another daemon"});
                if (stream->seal && stream->seal->key() != *seal_key) {
                    // A new run of the sending daemon (a new key) while a link of its earlier run
                    // still holds the group: its persistent connections try again once that closes.
                    return Outcome(
                        proto::Error{"group " + key + " is still fed by an earlier run of the daemon at " +
                                     sender.to_string() + " (another key): try again when its link closes"});
                }
                stream->inlets.push_back(std::move(inlet));
                return Outcome(stream);
            }
        }
    }
    if (!group.address().is_v4() || !group.address().is_multicast())
        return Outcome(proto::Error{key + " is not an IPv4 multicast group"});
    if (interface_.is_loopback())
        return Outcome(proto::Error{"mcast needs a daemon listening on a network interface, not loopback"});
    auto joined = std::make_shared<Group>(io_);
    joined->key = key;
    boost::system::error_code ec;
    joined->socket.open(asio::ip::udp::v4(), ec);
    if (!ec)
        joined->socket.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec)
        joined->socket.bind(group, ec);  // bound to the group: only its datagrams arrive
    if (!ec) {
        if (interface_.is_v4() && !interface_.is_unspecified())
            joined->socket.set_option(
                asio::ip::multicast::join_group(group.address().to_v4(), interface_.to_v4()), ec);
        else
            joined->socket.set_option(asio::ip::multicast::join_group(group.address()), ec);
    }
    if (!ec)
        joined->socket.non_blocking(true, ec);
    if (ec)
        return Outcome(proto::Error{"cannot join multicast group " + key + ": " + ec.message()});
    joined->socket.set_option(asio::socket_base::receive_buffer_size(socket_buffer_bytes), ec);
    auto stream = std::make_shared<Stream>();
    stream->inlets.push_back(std::move(inlet));
    stream->sender = std::move(sender);
    if (seal_key)
        stream->seal = std::make_unique<proto::DatagramSeal>(*seal_key);
    DatagramStream::Limits limits;
    limits.timeout = config_.reassembly_timeout;
    limits.start_anywhere = true;  // a group may have sent long before this daemon joined
    limits.first = first_message;
    stream->datagrams = std::make_shared<DatagramStream>(budget_, limits);
    stream->owner = this;
    stream->group = joined;
    joined->stream = stream;
    groups_[key] = joined;
    asio::co_spawn(io_, group_loop(joined), asio::detached);
    spdlog::info("joined multicast group {} on {}", key, interface_.to_string());
    return Outcome(stream);
}

std::shared_ptr<carriers::McastSender> UdpSocket::mcast_sender(const std::string& source,
                                                               const asio::ip::udp::endpoint& group) {
    if (auto known = senders_.find(source); known != senders_.end()) {
        if (auto sender = known->second.lock(); sender && sender->group() == group)
            return sender;
    }
    auto sender = std::make_shared<carriers::McastSender>(*this, group, source);
    senders_[source] = sender;
    return sender;
}

std::uint64_t UdpSocket::id(const Stream& stream) {
    return stream.id;
}

std::shared_ptr<const DatagramStream> UdpSocket::datagrams(const Stream& stream) {
    return stream.datagrams;
}

std::optional<proto::DatagramKey> UdpSocket::key(const Stream& stream) {
    if (!stream.seal)
        return std::nullopt;
    return stream.seal->key();
}

UdpSocket::McastStream& UdpSocket::mcast_stream(const std::string& source) {
    auto& known = mcast_streams_[source];
    if (!known)
        known = std::make_unique<McastStream>(proto::random_datagram_key());
    return *known;
}

DatagramMarks UdpSocket::marks_for(int dscp) const {
    boost::system::error_code ec;
    const auto local = socket_.local_endpoint(ec);
    DatagramMarks marks(!ec && local.address().is_v6() ? AF_INET6 : AF_INET, dscp);
    if (priority_refused_)
        marks.drop_priority();
    return marks;
}

bool UdpSocket::send(const asio::ip::udp::endpoint& to, std::uint64_t stream, std::uint64_t message,
                     proto::ByteView record, DatagramMarks* marks, proto::DatagramSeal* seal) {
    const std::size_t fragment = config_.fragment_bytes;
    const auto count = proto::fragment_count(record.size(), fragment);
    const bool sealed = seal != nullptr;
    // Headers (and tags) of one sendmmsg call, each in its own slot; the fragments are sent from
    // the record itself (gather), not copied, unless sealed: then from their sealed copies.
    std::array<std::array<std::uint8_t, proto::max_datagram_header>, datagrams_per_call> headers{};
    std::array<std::array<std::uint8_t, proto::datagram_sealed_tag_size>, datagrams_per_call> tags{};
    thread_local std::vector<std::uint8_t> sealed_bodies;
    if (sealed)
        sealed_bodies.resize(std::max(sealed_bodies.size(), datagrams_per_call * fragment));
    std::array<iovec, datagrams_per_call * 3> pieces{};
    std::array<mmsghdr, datagrams_per_call> messages{};
    proto::Bytes header;
    std::uint64_t index = 0;
    while (index < count) {
        const std::size_t batch = std::min<std::uint64_t>(datagrams_per_call, count - index);
        for (std::size_t i = 0; i < batch; ++i) {
            const std::uint64_t fragment_index = index + i;
            header.clear();
            proto::append_datagram_header(header,
                                          {stream, message, record.size(), fragment, fragment_index, sealed});
            std::copy(header.begin(), header.end(), headers[i].begin());
            const std::size_t begin = fragment_index * fragment;
            const std::size_t size = std::min(record.size() - begin, fragment);
            proto::ByteView body(record.data() + begin, size);
            if (sealed) {
                std::uint8_t* out = sealed_bodies.data() + i * fragment;
                seal->seal({headers[i].data(), header.size()}, message, fragment_index, body, out,
                           tags[i].data());
                body = {out, size};
            }
            std::size_t used = 0;
            pieces[3 * i + used++] = {headers[i].data(), header.size()};
            if (size != 0)
                pieces[3 * i + used++] = {const_cast<std::uint8_t*>(body.data()), size};
            if (sealed)
                pieces[3 * i + used++] = {tags[i].data(), tags[i].size()};
            messages[i] = {};
            messages[i].msg_hdr.msg_name = const_cast<void*>(static_cast<const void*>(to.data()));
            messages[i].msg_hdr.msg_namelen = static_cast<socklen_t>(to.size());
            messages[i].msg_hdr.msg_iov = &pieces[3 * i];
            messages[i].msg_hdr.msg_iovlen = used;
            if (marks) {
                messages[i].msg_hdr.msg_control = marks->data();
                messages[i].msg_hdr.msg_controllen = marks->size();
            }
        }
        int sent = ::sendmmsg(socket_.native_handle(), messages.data(), static_cast<unsigned>(batch), 0);
        if (sent < 0 && errno == EINVAL && marks && !priority_refused_) {
            // Linux before 6.13 takes no SO_PRIORITY as ancillary data: the DSCP alone still goes.
            priority_refused_ = true;
            spdlog::warn(
                "this kernel does not take SO_PRIORITY per datagram: udp/mcast connections with "
                "qos.dscp carry their DSCP but not the matching socket priority");
            marks->drop_priority();
            for (std::size_t i = 0; i < batch; ++i)
                messages[i].msg_hdr.msg_controllen = marks->size();
            sent = ::sendmmsg(socket_.native_handle(), messages.data(), static_cast<unsigned>(batch), 0);
        }
        if (sent <= 0) {
            // Buffer full (EAGAIN) or the network is unreachable: best effort, the receiver will
            // count the message lost. Nothing here may wait: the daemon has one thread.
            counters_.send_failures += count - index;
            return false;
        }
        counters_.datagrams_sent += static_cast<std::uint64_t>(sent);
        index += static_cast<std::uint64_t>(sent);
    }
    return true;
}

void UdpSocket::send_counted(const asio::ip::udp::endpoint& to, std::uint64_t stream,
                             std::uint64_t& next_message, proto::ByteView record, UdpSendCounters& counters,
                             const std::string& description, DatagramMarks* marks,
                             proto::DatagramSeal* seal) {
    if (record.size() > config_.max_message) {
        // Never numbered: the receiver sees no gap for it; the sender's counter says it.
        if (counters.dropped_too_large++ == 0) {
            spdlog::warn(
                "{}: a message of {} bytes is larger than the udp carrier's limit {} (udp_max_message): "
                "dropped; such drops are counted in stats",
                description, record.size(), config_.max_message);
        }
        return;
    }
    if (marks && priority_refused_)
        marks->drop_priority();
    if (send(to, stream, next_message++, record, marks, seal))
        ++counters.messages;
    else
        ++counters.dropped_send;
    counters.datagrams += proto::fragment_count(record.size(), config_.fragment_bytes);
}

Task<void> UdpSocket::receive_loop() {
    while (!stopped_) {
        auto [ec] = co_await socket_.async_wait(asio::socket_base::wait_read, use_nothrow);
        if (ec) {
            if (stopped_ || ec == asio::error::operation_aborted)
                co_return;
            continue;
        }
        drain(socket_, nullptr);
    }
}

Task<void> UdpSocket::group_loop(std::shared_ptr<Group> group) {
    while (!stopped_ && group->socket.is_open()) {
        auto [ec] = co_await group->socket.async_wait(asio::socket_base::wait_read, use_nothrow);
        if (ec)
            co_return;  // closed: its last connection went, or the daemon stops
        auto stream = group->stream.lock();
        if (!stream)
            co_return;
        drain(group->socket, stream.get());
    }
}

void UdpSocket::drain(asio::ip::udp::socket& socket, Stream* fixed) {
    // Take everything that is waiting before going back to the event loop: a 1 MiB message
    // arrives as hundreds of datagrams.
    thread_local std::vector<std::uint8_t> buffer(largest_datagram);
    asio::ip::udp::endpoint from;
    for (;;) {
        boost::system::error_code receive_error;
        const std::size_t n = socket.receive_from(asio::buffer(buffer), from, 0, receive_error);
        if (receive_error)
            return;
        ++counters_.datagrams_received;
        take({buffer.data(), n}, from, fixed);
    }
}

void UdpSocket::take(proto::ByteView bytes, const asio::ip::udp::endpoint& from, Stream* fixed) {
    auto decoded = proto::decode_datagram(bytes, config_.max_message);
    if (!decoded) {
        ++counters_.bad_datagrams;
        spdlog::debug("udp: bad datagram from {}: {}", from.address().to_string(), decoded.error().message);
        return;
    }
    std::shared_ptr<Stream> looked_up;
    if (!fixed) {
        const auto it = streams_.find(decoded->header.stream);
        looked_up = it == streams_.end() ? nullptr : it->second.lock();
    }
    Stream* stream = fixed ? fixed : looked_up.get();
    if (!stream) {
        ++counters_.unknown_stream;
        return;
    }
    if (stream->sender != from.address()) {
        ++counters_.wrong_sender;
        return;
    }
    if (stream->seal || decoded->header.sealed) {
        // Opened before the stream sees it: a forged datagram must not move its position.
        thread_local std::vector<std::uint8_t> opened(largest_datagram);
        const auto& header = decoded->header;
        if (!stream->seal || !header.sealed ||
            !stream->seal->open(decoded->head, header.message, header.index, decoded->fragment, decoded->tag,
                                opened.data())) {
            ++counters_.bad_mac;
            return;
        }
        decoded->fragment = {opened.data(), decoded->fragment.size()};
    }
    auto message = stream->datagrams->take(*decoded, DatagramStream::Clock::now());
    if (!message)
        return;
    const auto record = proto::decode_record(message->record);
    std::erase_if(stream->inlets, [](const std::weak_ptr<Inlet>& inlet) { return inlet.expired(); });
    for (const auto& weak : stream->inlets) {
        auto inlet = weak.lock();
        if (!inlet || inlet->port()->closed())
            continue;
        // The record must be the connection's source's: a sender may only carry what it attached.
        if (!record || record->source != inlet->source()) {
            ++counters_.bad_datagrams;
            spdlog::debug("udp: a message is not from {}: dropped", inlet->source());
            return;
        }
        if (inlet->full()) {
            // A strict queue that is full cannot hold a datagram writer back: the message is dropped.
            ++inlet->dropped_full;
            continue;
        }
        inlet->deliver(*message);
    }
}

Task<void> UdpSocket::expire_loop() {
    asio::steady_timer tick(io_);
    while (!stopped_) {
        // At least a millisecond: a tiny timeout must not make this loop spin.
        tick.expires_after(std::max<std::chrono::milliseconds>(config_.reassembly_timeout / 4,
                                                               std::chrono::milliseconds(1)));
        auto [ec] = co_await tick.async_wait(use_nothrow);
        if (ec || stopped_)
            co_return;
        const auto now = DatagramStream::Clock::now();
        for (auto& [id, weak] : streams_) {
            if (auto stream = weak.lock())
                stream->datagrams->expire(now);
        }
        std::erase_if(groups_, [](const auto& entry) { return entry.second.expired(); });
        for (auto& [key, weak] : groups_) {
            if (auto group = weak.lock()) {
                if (auto stream = group->stream.lock())
                    stream->datagrams->expire(now);
            }
        }
    }
}

}  // namespace plexus::daemon
