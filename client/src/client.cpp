#include <spdlog/fmt/fmt.h>

#include "connection.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/cbor.hpp"
#include "plexus/proto/defaults.hpp"
#include "plexus/proto/discovery.hpp"
#include "plexus/proto/message.hpp"

namespace plexus {

namespace {

[[noreturn]] void throw_reply(const proto::Reply& reply) {
    const auto code =
        static_cast<ErrorCode>(std::clamp<std::uint32_t>(static_cast<std::uint32_t>(reply.code), 1, 4));
    throw Error(code, reply.body.value("error", std::string("refused by plexusd")));
}

nlohmann::json checked(const proto::Reply& reply) {
    if (reply.code != proto::ReplyCode::ok)
        throw_reply(reply);
    return reply.body;
}

}  // namespace

// --- Port ---

Port::Port(std::shared_ptr<detail::Connection> connection, std::string name, std::uint64_t handle)
    : connection_(std::move(connection)),
      name_(std::move(name)),
      handle_(handle),
      ready_(std::make_unique<detail::Inbox>()) {}

Port::Port(Port&& other) noexcept
    : connection_(std::move(other.connection_)),
      name_(std::move(other.name_)),
      handle_(other.handle_),
      next_seq_(other.next_seq_),
      ready_(std::move(other.ready_)) {}

Port& Port::operator=(Port&& other) noexcept {
    if (this != &other) {
        try {
            close();
        } catch (...) {
            // A failed close of the old port must not stop the move.
        }
        connection_ = std::move(other.connection_);
        name_ = std::move(other.name_);
        handle_ = other.handle_;
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
    if (!connection_)
        throw Error(ErrorCode::usage, "port " + name_ + " is closed");
    thread_local proto::Bytes payload;
    payload.clear();
    if (value.is_binary() && !value.get_binary().has_subtype() &&
        value.get_binary().size() >= detail::large_payload_frame) {
        // A large blob (an image, a point cloud) leaves from the Value itself: only its CBOR head
        // is written here, and no copy of it is made on the way to the socket.
        const auto& bytes = value.get_binary();
        proto::append_byte_string_head(payload, bytes.size());
        connection_->write(handle_, name_, next_seq_++, payload, {bytes.data(), bytes.size()}, flush);
        return;
    }
    proto::encode_cbor(value, payload);
    connection_->write(handle_, name_, next_seq_++, payload, {}, flush);
}

void Port::flush() {
    if (connection_)
        connection_->flush();
}

std::optional<Received> Port::read(std::chrono::milliseconds timeout) {
    // One look at connection_ (close() resets it); no reference count per read: the Client keeps
    // the connection alive.
    detail::Connection* const connection = connection_.get();
    if (!connection)
        throw Error(ErrorCode::usage, "port " + name_ + " is closed");
    auto& inbox = *ready_;
    if (inbox.segments.empty()) {
        if (!connection->read_all(handle_, timeout, inbox.segments))
            return std::nullopt;
        inbox.next = 0;
    }
    auto& segment = inbox.segments.front();
    if (segment.whole) {
        Received message = std::move(*segment.whole);
        inbox.segments.pop_front();
        inbox.next = 0;
        return message;
    }
    const proto::ByteView record = segment.records[inbox.next++];
    std::shared_ptr<const proto::Bytes> block;  // keeps the last record of a segment alive past it
    if (inbox.next == segment.records.size()) {
        block = std::move(segment.block);
        inbox.segments.pop_front();
        inbox.next = 0;
    }
    auto view = proto::decode_record(record);
    if (!view)
        throw Error(ErrorCode::refused, "bad message record: " + view.error().message);
    auto data = proto::decode_cbor(view->payload);
    if (!data)
        throw Error(ErrorCode::refused,
                    "bad payload from " + std::string(view->source) + ": " + data.error().message);
    return Received{{std::string(view->source), view->seq, view->time_ns}, std::move(*data)};
}

void Port::close() {
    if (!connection_)
        return;
    auto connection = std::move(connection_);
    connection_ = nullptr;
    connection->flush();
    connection->forget(handle_);
    checked(connection->request({{"op", "close"}, {"handle", handle_}}, std::chrono::milliseconds(10000)));
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
    auto found = proto::find_names(flag);
    if (!found)
        throw Error(ErrorCode::usage, found.error().message);
    return {found->address, found->how()};
}

// --- Client ---

Client::Client() : Client(Options{}) {}

Client::Client(Options options)
    : socket_(options.socket.empty() ? proto::default_socket() : options.socket),
      connection_(detail::Connection::to_daemon(socket_)) {}

std::optional<Value> Client::ask_names(const std::string& names_address, const Value& body) {
    auto connection = detail::Connection::to_tcp(names_address);
    auto reply = connection->request(body, std::chrono::milliseconds(10000));
    if (reply.code == proto::ReplyCode::no)
        return std::nullopt;
    return checked(reply);
}

Client::~Client() = default;

Value Client::request(const Value& body) {
    return checked(connection_->request(body, std::chrono::milliseconds(10000)));
}

Port Client::open(const std::string& name, PortOptions options) {
    nlohmann::json body{{"op", "open"},
                        {"port", name},
                        {"policy", options.policy == QueuePolicy::strict ? "strict" : "latest"}};
    if (options.capacity > 0)
        body["capacity"] = options.capacity;
    auto reply = request(body);
    return Port(connection_, name, reply.at("handle").get<std::uint64_t>());
}

std::string Client::connect(const std::string& source, const std::string& destination,
                            const std::string& carrier, bool persist) {
    auto reply = request({{"op", "connect"},
                          {"source", source},
                          {"destination", destination},
                          {"carrier", carrier},
                          {"persist", persist}});
    return reply.value("carrier", carrier);
}

void Client::disconnect(const std::string& source, const std::string& destination) {
    request({{"op", "disconnect"}, {"source", source}, {"destination", destination}});
}

Value Client::list() {
    return request({{"op", "list"}});
}

std::optional<Value> Client::lookup(const std::string& port) {
    auto reply = connection_->request({{"op", "lookup"}, {"port", port}}, std::chrono::milliseconds(10000));
    if (reply.code == proto::ReplyCode::no)
        return std::nullopt;
    return checked(reply);
}

Value Client::stats(const std::string& port) {
    return request({{"op", "stats"}, {"port", port}});
}

Value Client::ping(const std::string& port) {
    return request({{"op", "ping"}, {"port", port}});
}

}  // namespace plexus
