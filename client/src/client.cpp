#include <spdlog/fmt/fmt.h>

#include "callers.hpp"
#include "connection.hpp"
#include "daemon_link.hpp"
#include "large_payload.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/defaults.hpp"
#include "plexus/proto/discovery.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/name_operations.hpp"
#include "plexus/proto/operations.hpp"
#include "shm_regions.hpp"
#include "tcp_handshake.hpp"

namespace plexus {

using detail::checked;

namespace {

constexpr std::chrono::milliseconds control_timeout{10000};

[[noreturn]] void refuse_too_large(const std::string& port, std::size_t size, std::uint64_t limit) {
    throw Error(ErrorCode::refused,
                fmt::format("a message of {} bytes on {} is larger than the daemon's frame limit of {} bytes "
                            "(its max_frame): nothing was sent; send it in parts, or raise max_frame in the "
                            "daemon's config",
                            size, port, limit));
}

}  // namespace

// --- Port ---

Port::Port(std::shared_ptr<detail::DaemonLink> link, std::shared_ptr<detail::PortRecord> record)
    : link_(std::move(link)),
      record_(std::move(record)),
      name_(record_->name),
      ready_(std::make_unique<detail::Inbox>()) {
    std::lock_guard lock(record_->mutex);
    connection_ = read_connection_ = record_->connection;
    handle_ = read_handle_ = record_->handle;
    generation_ = read_generation_ = record_->generation.load(std::memory_order_relaxed);
}

Port::Port(Port&& other) noexcept
    : link_(std::move(other.link_)),
      record_(std::move(other.record_)),
      name_(std::move(other.name_)),
      connection_(std::move(other.connection_)),
      handle_(other.handle_),
      generation_(other.generation_),
      read_connection_(std::move(other.read_connection_)),
      read_handle_(other.read_handle_),
      read_generation_(other.read_generation_),
      next_seq_(other.next_seq_),
      ready_(std::move(other.ready_)) {}

Port& Port::operator=(Port&& other) noexcept {
    if (this != &other) {
        try {
            close();
        } catch (...) {
            // A failed close of the old port must not stop the move.
        }
        link_ = std::move(other.link_);
        record_ = std::move(other.record_);
        name_ = std::move(other.name_);
        connection_ = std::move(other.connection_);
        handle_ = other.handle_;
        generation_ = other.generation_;
        read_connection_ = std::move(other.read_connection_);
        read_handle_ = other.read_handle_;
        read_generation_ = other.read_generation_;
        next_seq_ = other.next_seq_;
        ready_ = std::move(other.ready_);
    }
    return *this;
}

Port::~Port() {
    try {
        close();
    } catch (...) {
        // Destructors do not throw; the daemon closes the port when the client goes anyway.
    }
}

void Port::write(const Value& value, bool flush) {
    if (!link_)
        throw Error(ErrorCode::usage, "port " + name_ + " is closed");
    // Deeper values are encoded, and then no reader can decode them (proto::max_cbor_depth).
    if (proto::nesting_depth(value) > proto::max_cbor_depth) [[unlikely]] {
        throw Error(ErrorCode::usage,
                    proto::check_value_depth(value, "the message written on " + name_).error().message);
    }
    thread_local proto::Bytes payload;
    payload.clear();
    if (value.is_binary() && !value.get_binary().has_subtype() &&
        value.get_binary().size() >= detail::large_payload_frame) {
        // A large blob (an image, a point cloud) leaves from the Value itself: only its CBOR head
        // is written here, and no copy of it is made on the way to the socket.
        const auto& bytes = value.get_binary();
        proto::append_byte_string_head(payload, bytes.size());
        send(next_seq_++, payload, {bytes.data(), bytes.size()}, flush);
        return;
    }
    proto::encode_cbor(value, payload);
    send(next_seq_++, payload, {}, flush);
}

void Port::write_encoded(std::span<const std::uint8_t> cbor, bool flush) {
    if (!link_)
        throw Error(ErrorCode::usage, "port " + name_ + " is closed");
    send(next_seq_++, cbor, {}, flush);
}

void Port::write_blob(std::span<const std::uint8_t> head, std::span<const std::uint8_t> body, bool flush) {
    if (!link_)
        throw Error(ErrorCode::usage, "port " + name_ + " is closed");
    // The CBOR byte string's head and `head` go first; a large `body` is the tail, sent from where
    // it is. A small one joins them here, as write() encodes a small blob: one piece, no allocation.
    thread_local proto::Bytes payload;
    payload.clear();
    proto::append_byte_string_head(payload, head.size() + body.size());
    payload.insert(payload.end(), head.begin(), head.end());
    if (body.size() < detail::large_payload_frame) {
        payload.insert(payload.end(), body.begin(), body.end());
        send(next_seq_++, payload, {}, flush);
        return;
    }
    send(next_seq_++, payload, body, flush);
}

void Port::send(std::uint64_t seq, std::span<const std::uint8_t> payload, std::span<const std::uint8_t> tail,
                bool flush) {
    // Refused here, before it is sent or held: the daemon would cut the whole session off for it
    // (and every port of this client with it), and held it would fail again at every reconnection.
    const std::size_t size = payload.size() + tail.size();
    if (detail::frame_body_size(name_, seq, size) > link_->max_frame()) [[unlikely]]
        refuse_too_large(name_, size, link_->max_frame());
    for (;;) {
        // The hot path: one acquire load compared with the cached generation, no lock.
        if (connection_ && record_->generation.load(std::memory_order_acquire) == generation_) [[likely]] {
            try {
                connection_->write(handle_, name_, seq, payload, tail, flush);
                return;
            } catch (const Error&) {
                if (!connection_->broken())
                    throw;
                // The daemon went away: this message is held below and sent after reconnecting.
                link_->lost(connection_);
            }
        }
        std::lock_guard lock(record_->mutex);
        generation_ = record_->generation.load(std::memory_order_relaxed);
        connection_ = record_->connection;
        handle_ = record_->handle;
        if (!connection_) {
            record_->hold_locked(seq, payload, tail);
            return;
        }
    }
}

void Port::flush() {
    if (!link_ || !connection_ || record_->generation.load(std::memory_order_acquire) != generation_)
        return;  // nothing buffered on a connection that is gone can be sent anyway
    try {
        connection_->flush();
    } catch (const Error&) {
        if (!connection_->broken())
            throw;
        link_->lost(connection_);
    }
}

std::uint64_t Port::dropped_while_disconnected() const {
    if (!record_)
        return 0;
    std::lock_guard lock(record_->mutex);
    return record_->dropped;
}

bool Port::take(std::chrono::milliseconds timeout) {
    if (read_connection_ && record_->generation.load(std::memory_order_acquire) == read_generation_)
        [[likely]] {
        try {
            return read_connection_->read_all(read_handle_, timeout, ready_->segments);
        } catch (const Error&) {
            if (!read_connection_->broken())
                throw;
            link_->lost(read_connection_);
        }
    }
    return take_slow(std::chrono::steady_clock::now() + timeout);
}

bool Port::take_slow(std::chrono::steady_clock::time_point deadline) {
    using std::chrono::milliseconds;
    auto& segments = ready_->segments;
    for (;;) {
        if (read_connection_ && record_->generation.load(std::memory_order_acquire) != read_generation_) {
            // Messages that reached the old connection before its daemon went are read first. Its
            // peer is gone, so this does not wait: the socket has data, or it ends (and throws).
            const auto left =
                std::max(milliseconds(0),
                         std::chrono::ceil<milliseconds>(deadline - std::chrono::steady_clock::now()));
            try {
                if (read_connection_->read_all(read_handle_, left, segments))
                    return true;
            } catch (const Error&) {
                // Broken, and nothing left in it.
            }
        }
        {
            std::lock_guard lock(record_->mutex);
            read_generation_ = record_->generation.load(std::memory_order_relaxed);
            read_connection_ = record_->connection;
            read_handle_ = record_->handle;
        }
        const auto left = std::max(
            milliseconds(0), std::chrono::ceil<milliseconds>(deadline - std::chrono::steady_clock::now()));
        if (!read_connection_) {
            if (!link_->wait_for_change(*record_, read_generation_, deadline))
                return false;
            continue;
        }
        try {
            return read_connection_->read_all(read_handle_, left, segments);
        } catch (const Error&) {
            if (!read_connection_->broken())
                throw;
            link_->lost(read_connection_);
        }
        if (std::chrono::steady_clock::now() >= deadline)
            return false;
    }
}

bool Port::next_ready(std::chrono::milliseconds timeout) {
    if (!link_)
        throw Error(ErrorCode::usage, "port " + name_ + " is closed");
    auto& inbox = *ready_;
    if (!inbox.segments.empty())
        return true;
    if (!take(timeout))
        return false;
    inbox.next = 0;
    return true;
}

std::optional<Received> Port::read(std::chrono::milliseconds timeout) {
    if (!next_ready(timeout))
        return std::nullopt;
    auto& inbox = *ready_;
    auto& segment = inbox.segments.front();
    if (segment.whole) {
        Received message = std::move(*segment.whole);
        inbox.segments.pop_front();
        inbox.next = 0;
        return message;
    }
    if (segment.lease) {
        // Copied out of shared memory now; the slot is released as the segment goes.
        const auto lease = std::move(segment.lease);
        inbox.segments.pop_front();
        inbox.next = 0;
        return detail::ShmRegions::copy_out(*lease);
    }
    const proto::ByteView record = segment.records[inbox.next++];
    std::shared_ptr<const proto::Bytes> block;  // keeps the last record of a segment alive past it
    if (inbox.next == segment.records.size()) {
        block = std::move(segment.block);
        inbox.segments.pop_front();
        inbox.next = 0;
    }
    return detail::received_of(record);
}

bool Port::report(const Value& counters) {
    if (!link_)
        throw Error(ErrorCode::usage, "port is closed");
    const auto [connection, handle] = current();
    if (!connection)
        return false;
    try {
        checked(connection->request(proto::ReportRequest{handle, counters}.encode(), control_timeout));
    } catch (const Error&) {
        if (!connection->broken())
            throw;
        link_->lost(connection);
        return false;
    }
    return true;
}

void Port::close() {
    if (!link_)
        return;
    auto link = std::move(link_);
    link_ = nullptr;
    connection_.reset();
    read_connection_.reset();
    link->close(record_, control_timeout);
}

// --- Subscription ---

Subscription::Subscription(Port& port, std::function<void(const Received&)> callback)
    : thread_([&port, callback = std::move(callback)](std::stop_token stop) {
          while (!stop.stop_requested()) {
              try {
                  if (auto message = port.read(std::chrono::milliseconds(100)))
                      callback(*message);
              } catch (const Error&) {
                  return;  // the port or the connection closed
              }
          }
      }) {}

Subscription::~Subscription() = default;

NamesLocation find_names(const std::optional<std::string>& flag) {
    // With the secret, discovery takes only a name server that proves it holds it.
    const auto secret = detail::secret_from_environment();
    auto found = proto::find_names(flag, {}, std::chrono::milliseconds(600), secret ? &*secret : nullptr);
    if (!found)
        throw Error(ErrorCode::usage, found.error().message);
    return {found->address, found->how()};
}

// --- Client ---

Client::Client() : Client(Options{}) {}

Client::Client(Options options)
    : socket_(options.socket.empty() ? proto::default_socket() : options.socket),
      link_(std::make_shared<detail::DaemonLink>(socket_)),
      callers_(std::make_shared<Callers>()) {}

std::optional<Value> Client::ask_names(const std::string& names_address, const Value& body) {
    auto connection = detail::Connection::to_names(names_address);
    auto reply = connection->request(body, control_timeout);
    if (reply.code == proto::ReplyCode::no)
        return std::nullopt;
    return checked(reply);
}

Client::~Client() {
    // Ports may outlive the Client (they keep the link); reconnection ends with it.
    link_->stop();
}

Value Client::request(const Value& body) {
    return checked(link_->request(body, control_timeout));
}

Port Client::open(const std::string& name, PortOptions options) {
    return Port(link_, link_->open(name, options, control_timeout));
}

std::string Client::connect(const std::string& source, const std::string& destination,
                            const std::string& carrier, bool persist) {
    proto::ConnectRequest asked;
    asked.source = source;
    asked.destination = destination;
    asked.carrier = carrier;
    asked.persist = persist;
    const auto reply =
        detail::checked_as<proto::ConnectReply>(link_->request(asked.encode(), control_timeout));
    link_->remember({source, destination, carrier, persist});
    // An older daemon may leave the carrier out: the one asked for is then the one made.
    return reply.carrier.empty() ? carrier : reply.carrier;
}

void Client::disconnect(const std::string& source, const std::string& destination) {
    request(proto::DisconnectRequest{source, destination}.encode());
    link_->forget(source, destination);
}

Value Client::list() {
    return detail::checked_as<proto::ListReply>(
               link_->request(proto::ListRequest{}.encode(), control_timeout))
        .document;
}

std::optional<Value> Client::lookup(const std::string& port) {
    auto reply = link_->request(proto::LookupRequest{port}.encode(), control_timeout);
    if (reply.code == proto::ReplyCode::no)
        return std::nullopt;
    return detail::checked_as<proto::LookupReply>(reply).encode();
}

Value Client::stats(const std::string& port) {
    return detail::checked_as<proto::StatsReply>(
               link_->request(proto::StatsRequest{port}.encode(), control_timeout))
        .document;
}

Value Client::ping(const std::string& port) {
    return detail::checked_as<proto::PingReply>(
               link_->request(proto::PingRequest{port}.encode(), control_timeout))
        .encode();
}

void Client::on_state(std::function<void(ConnectionState)> callback) {
    link_->on_state(std::move(callback));
}

ConnectionState Client::state() const {
    return link_->state();
}

}  // namespace plexus
