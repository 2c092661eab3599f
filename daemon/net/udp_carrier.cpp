#include "udp_carrier.hpp"

#include <sys/socket.h>

#include <algorithm>
#include <array>

#include <spdlog/spdlog.h>

#include "../core/batch.hpp"
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

struct UdpCarrier::Stream {
    std::uint64_t id = 0;
    std::weak_ptr<Inlet> inlet;
    asio::ip::address sender;
    std::shared_ptr<DatagramStream> datagrams;
    UdpCarrier* carrier = nullptr;
    ~Stream() {
        if (carrier)
            carrier->streams_.erase(id);
    }
};

UdpCarrier::UdpCarrier(asio::io_context& io, UdpConfig config)
    : io_(io), config_(config), socket_(io), budget_(std::make_shared<ReassemblyBudget>()) {
    budget_->max_bytes = config_.reassembly_bytes;
}

UdpCarrier::~UdpCarrier() {
    // Streams may outlive the carrier in sessions still being torn down: they must not reach back.
    for (auto& [id, weak] : streams_) {
        if (auto stream = weak.lock())
            stream->carrier = nullptr;
    }
}

proto::Status UdpCarrier::bind(const asio::ip::address& address, std::uint16_t port) {
    boost::system::error_code ec;
    const asio::ip::udp::endpoint endpoint(address, port);
    socket_.open(endpoint.protocol(), ec);
    if (!ec)
        socket_.bind(endpoint, ec);
    if (ec) {
        return proto::Error{"cannot listen on UDP " + address.to_string() + ":" + std::to_string(port) +
                            " (the udp carrier uses the TCP port's number): " + ec.message()};
    }
    socket_.non_blocking(true, ec);
    socket_.set_option(asio::socket_base::send_buffer_size(socket_buffer_bytes), ec);
    socket_.set_option(asio::socket_base::receive_buffer_size(socket_buffer_bytes), ec);
    return proto::Ok{};
}

void UdpCarrier::start() {
    asio::co_spawn(io_, receive_loop(), asio::detached);
    asio::co_spawn(io_, expire_loop(), asio::detached);
}

void UdpCarrier::stop() {
    stopped_ = true;
    boost::system::error_code ignored;
    socket_.close(ignored);
}

std::uint16_t UdpCarrier::port() const {
    boost::system::error_code ec;
    const auto local = socket_.local_endpoint(ec);
    return ec ? 0 : local.port();
}

std::shared_ptr<UdpCarrier::Stream> UdpCarrier::open_stream(std::weak_ptr<Inlet> inlet,
                                                            asio::ip::address sender) {
    auto stream = std::make_shared<Stream>();
    stream->id = next_stream_++;
    stream->inlet = std::move(inlet);
    stream->sender = std::move(sender);
    DatagramStream::Limits limits;
    limits.timeout = config_.reassembly_timeout;
    stream->datagrams = std::make_shared<DatagramStream>(budget_, limits);
    stream->carrier = this;
    streams_[stream->id] = stream;
    return stream;
}

std::uint64_t UdpCarrier::id(const Stream& stream) {
    return stream.id;
}

std::shared_ptr<const DatagramStream> UdpCarrier::datagrams(const Stream& stream) {
    return stream.datagrams;
}

bool UdpCarrier::send(const asio::ip::udp::endpoint& to, std::uint64_t stream, std::uint64_t message,
                      proto::ByteView record) {
    const std::size_t fragment = config_.fragment_bytes;
    const auto count = proto::fragment_count(record.size(), fragment);
    // Headers of one sendmmsg call, each in its own slot; the fragments are sent from the record
    // itself (gather), not copied.
    std::array<std::array<std::uint8_t, proto::max_datagram_header>, datagrams_per_call> headers{};
    std::array<iovec, datagrams_per_call * 2> pieces{};
    std::array<mmsghdr, datagrams_per_call> messages{};
    proto::Bytes header;
    std::uint64_t index = 0;
    while (index < count) {
        const std::size_t batch = std::min<std::uint64_t>(datagrams_per_call, count - index);
        for (std::size_t i = 0; i < batch; ++i) {
            const std::uint64_t fragment_index = index + i;
            header.clear();
            proto::append_datagram_header(header,
                                          {stream, message, record.size(), fragment, fragment_index, false});
            std::copy(header.begin(), header.end(), headers[i].begin());
            const std::size_t begin = fragment_index * fragment;
            const std::size_t size = std::min(record.size() - begin, fragment);
            pieces[2 * i] = {headers[i].data(), header.size()};
            pieces[2 * i + 1] = {const_cast<std::uint8_t*>(record.data() + begin), size};
            messages[i] = {};
            messages[i].msg_hdr.msg_name = const_cast<void*>(static_cast<const void*>(to.data()));
            messages[i].msg_hdr.msg_namelen = static_cast<socklen_t>(to.size());
            messages[i].msg_hdr.msg_iov = &pieces[2 * i];
            messages[i].msg_hdr.msg_iovlen = size == 0 ? 1 : 2;
        }
        const int sent =
            ::sendmmsg(socket_.native_handle(), messages.data(), static_cast<unsigned>(batch), 0);
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

Task<void> UdpCarrier::receive_loop() {
    std::vector<std::uint8_t> buffer(largest_datagram);
    asio::ip::udp::endpoint from;
    while (!stopped_) {
        auto [ec] = co_await socket_.async_wait(asio::socket_base::wait_read, use_nothrow);
        if (ec) {
            if (stopped_ || ec == asio::error::operation_aborted)
                co_return;
            continue;
        }
        // Take everything that is waiting before going back to the event loop: a 1 MiB message
        // arrives as hundreds of datagrams.
        for (;;) {
            boost::system::error_code receive_error;
            const std::size_t n = socket_.receive_from(asio::buffer(buffer), from, 0, receive_error);
            if (receive_error)
                break;
            ++counters_.datagrams_received;
            take({buffer.data(), n}, from);
        }
    }
}

void UdpCarrier::take(proto::ByteView bytes, const asio::ip::udp::endpoint& from) {
    auto decoded = proto::decode_datagram(bytes, config_.max_message);
    if (!decoded) {
        ++counters_.bad_datagrams;
        spdlog::debug("udp: bad datagram from {}: {}", from.address().to_string(), decoded.error().message);
        return;
    }
    const auto it = streams_.find(decoded->header.stream);
    auto stream = it == streams_.end() ? nullptr : it->second.lock();
    if (!stream) {
        ++counters_.unknown_stream;
        return;
    }
    if (stream->sender != from.address()) {
        ++counters_.wrong_sender;
        return;
    }
    auto message = stream->datagrams->take(*decoded, DatagramStream::Clock::now());
    if (!message)
        return;
    auto inlet = stream->inlet.lock();
    if (!inlet || inlet->port()->closed())
        return;
    // The record must be the connection's source's: a sender may only carry what it attached.
    const auto record = proto::decode_record(message->record);
    if (!record || record->source != inlet->source()) {
        ++counters_.bad_datagrams;
        spdlog::debug("udp: a message on stream {} is not from {}: dropped", stream->id, inlet->source());
        return;
    }
    if (inlet->full()) {
        // A strict queue that is full cannot hold a udp writer back: the message is dropped.
        ++inlet->dropped_full;
        return;
    }
    inlet->deliver(*message);
}

Task<void> UdpCarrier::expire_loop() {
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
    }
}

void UdpLink::deliver(const Message& message) {
    for_each_record(message, [this](const Message& single) {
        if (single.record.size() > carrier_.config().max_message) {
            if (counters_.dropped_too_large++ == 0) {
                spdlog::warn(
                    "{}: a message of {} bytes is larger than the udp carrier's limit {} "
                    "(udp_max_message): dropped; such drops are counted in stats",
                    description_, single.record.size(), carrier_.config().max_message);
            }
            return;
        }
        const std::uint64_t number = next_message_++;
        if (carrier_.send(to_, stream_, number, single.record))
            ++counters_.messages;
        else
            ++counters_.dropped_send;
        counters_.datagrams += proto::fragment_count(single.record.size(), carrier_.config().fragment_bytes);
    });
}

}  // namespace plexus::daemon
