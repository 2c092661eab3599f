#include "daemon_link.hpp"
#include "plexus/proto/operations.hpp"

#include <fcntl.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <random>

namespace plexus::detail {

namespace {

using namespace std::chrono_literals;

// Back-off between attempts to reach a daemon that went away: from the first to the last,
// doubling, each with +-25% jitter so that the components of a machine do not all knock at once.
constexpr auto first_delay = 50ms;
constexpr auto last_delay = 2000ms;
// How long a reconnection waits for the other ends of its connections (components that reconnect
// too) before sending what its ports held anyway; the connections are still retried after.
constexpr auto wait_for_peers = 3000ms;
constexpr auto restore_timeout = 10000ms;
// How often an idle client looks whether its daemon hung up (a busy one notices at once).
constexpr auto idle_check = std::chrono::milliseconds(200);

nlohmann::json open_body(const std::string& name, const PortOptions& options) {
    proto::OpenRequest open;
    open.port = name;
    open.policy = options.policy == QueuePolicy::strict ? "strict" : "latest";
    if (options.capacity > 0)
        open.capacity = options.capacity;
    open.serve = options.serve;
    return open.encode();
}

nlohmann::json connect_body(const ConnectionSpec& spec) {
    proto::ConnectRequest connect;
    connect.source = spec.source;
    connect.destination = spec.destination;
    connect.carrier = spec.carrier;
    connect.persist = spec.persist;
    return connect.encode();
}

}  // namespace

nlohmann::json checked(const proto::Reply& reply) {
    if (reply.code != proto::ReplyCode::ok) {
        const auto code =
            static_cast<ErrorCode>(std::clamp<std::uint32_t>(static_cast<std::uint32_t>(reply.code), 1, 4));
        throw Error(code, reply.body.value("error", std::string("refused by plexusd")));
    }
    return reply.body;
}

void PortRecord::hold_locked(std::uint64_t seq, proto::ByteView payload, proto::ByteView tail) {
    HeldMessage message{seq, proto::Bytes(payload.begin(), payload.end())};
    message.payload.insert(message.payload.end(), tail.begin(), tail.end());
    held_bytes += message.payload.size();
    held.push_back(std::move(message));
    while (held.size() > held_messages_limit || (held_bytes > held_bytes_limit && held.size() > 1)) {
        held_bytes -= held.front().payload.size();
        held.pop_front();
        ++dropped;
    }
}

DaemonLink::DaemonLink(std::string socket_path)
    : path_(std::move(socket_path)), current_(Connection::to_daemon(path_)) {
    max_frame_.store(current_->peer_max_frame(), std::memory_order_relaxed);
    if (::pipe2(wake_pipe_, O_CLOEXEC | O_NONBLOCK) != 0)
        throw Error(ErrorCode::refused, "cannot create a pipe for the reconnection watcher");
    watcher_ = std::thread([this] { watch(); });
}

DaemonLink::~DaemonLink() {
    stop();
    ::close(wake_pipe_[0]);
    ::close(wake_pipe_[1]);
}

void DaemonLink::stop() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake();
    if (watcher_.joinable())
        watcher_.join();
}

void DaemonLink::wake() {
    const char byte = 1;
    [[maybe_unused]] const auto ignored = ::write(wake_pipe_[1], &byte, 1);  // full pipe: already woken
}

std::string DaemonLink::gone_message() const {
    return "the daemon at " + path_ + " is gone; reconnecting";
}

proto::Reply DaemonLink::request(const nlohmann::json& body, std::chrono::milliseconds timeout) {
    std::shared_ptr<Connection> connection;
    {
        std::lock_guard lock(mutex_);
        connection = current_;
    }
    if (!connection)
        throw Error(ErrorCode::refused, gone_message());
    try {
        return connection->request(body, timeout);
    } catch (const Error&) {
        if (!connection->broken())
            throw;
        lost(connection);
        throw Error(ErrorCode::refused, gone_message());
    }
}

std::shared_ptr<PortRecord> DaemonLink::open(const std::string& name, PortOptions options,
                                             std::chrono::milliseconds timeout) {
    std::shared_ptr<Connection> connection;
    {
        std::lock_guard lock(mutex_);
        connection = current_;
    }
    if (!connection)
        throw Error(ErrorCode::refused, gone_message());
    proto::Reply reply;
    try {
        reply = connection->request(open_body(name, options), timeout);
    } catch (const Error&) {
        if (!connection->broken())
            throw;
        lost(connection);
        throw Error(ErrorCode::refused, gone_message());
    }
    auto record = std::make_shared<PortRecord>(name, options);
    record->connection = connection;
    record->handle = checked_as<proto::OpenReply>(reply).handle;
    std::lock_guard lock(mutex_);
    // Opened on a daemon that went away meanwhile: the port went with it.
    if (current_ != connection)
        throw Error(ErrorCode::refused, gone_message());
    ports_.push_back(record);
    return record;
}

void DaemonLink::close(const std::shared_ptr<PortRecord>& record, std::chrono::milliseconds timeout) {
    std::shared_ptr<Connection> connection;
    std::uint64_t handle = 0;
    {
        std::lock_guard lock(mutex_);
        std::erase(ports_, record);
        std::lock_guard port(record->mutex);
        record->closed = true;
        record->held.clear();
        record->held_bytes = 0;
        connection = record->connection;
        handle = record->handle;
    }
    if (!connection)
        return;  // the daemon is away, and the port with it; a restore under way closes it
    try {
        connection->flush();
        connection->forget(handle);
        checked(connection->request(proto::CloseRequest{handle}.encode(), timeout));
    } catch (const Error&) {
        if (!connection->broken())
            throw;
        lost(connection);
    }
}

void DaemonLink::remember(const ConnectionSpec& spec) {
    std::lock_guard lock(mutex_);
    forget_locked(spec.source, spec.destination);
    connections_.push_back(spec);
}

void DaemonLink::forget(const std::string& source, const std::string& destination) {
    std::lock_guard lock(mutex_);
    forget_locked(source, destination);
}

void DaemonLink::forget_locked(const std::string& source, const std::string& destination) {
    const auto same = [&](const ConnectionSpec& spec) {
        return spec.source == source && spec.destination == destination;
    };
    std::erase_if(connections_, same);
    std::erase_if(to_make_, same);
}

void DaemonLink::lost(const std::shared_ptr<Connection>& connection) {
    if (mark_down(connection))
        wake();
}

bool DaemonLink::mark_down(const std::shared_ptr<Connection>& connection) {
    std::lock_guard lock(mutex_);
    for (const auto& record : ports_) {
        std::lock_guard port(record->mutex);
        if (record->connection != connection)
            continue;
        record->connection = nullptr;
        record->generation.fetch_add(1, std::memory_order_release);
    }
    if (!current_ || current_ != connection)
        return false;
    current_ = nullptr;
    state_ = ConnectionState::disconnected;
    return true;
}

bool DaemonLink::wait_for_change(const PortRecord& record, std::uint64_t generation,
                                 Clock::time_point deadline) {
    std::unique_lock lock(mutex_);
    return changed_.wait_until(
        lock, deadline, [&] { return record.generation.load(std::memory_order_acquire) != generation; });
}

void DaemonLink::on_state(std::function<void(ConnectionState)> callback) {
    std::lock_guard lock(mutex_);
    callback_ = std::move(callback);
}

ConnectionState DaemonLink::state() const {
    std::lock_guard lock(mutex_);
    return state_;
}

void DaemonLink::announce(ConnectionState state) {
    std::function<void(ConnectionState)> callback;
    {
        std::lock_guard lock(mutex_);
        callback = callback_;
    }
    if (!callback)
        return;
    try {
        callback(state);
    } catch (...) {
        // The component's callback must not end reconnection.
    }
}

bool DaemonLink::pause(std::chrono::milliseconds delay) {
    const auto deadline = Clock::now() + delay;
    for (;;) {
        {
            std::lock_guard lock(mutex_);
            if (stopping_)
                return false;
        }
        const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
        if (left <= 0ms)
            return true;
        pollfd wake{wake_pipe_[0], POLLIN, 0};
        if (::poll(&wake, 1, static_cast<int>(left.count())) > 0) {
            char bytes[64];
            while (::read(wake_pipe_[0], bytes, sizeof bytes) > 0) {
            }
        }
    }
}

void DaemonLink::watch() {
    std::minstd_rand random(std::random_device{}());
    std::uniform_real_distribution<double> jitter(0.75, 1.25);
    for (;;) {
        std::shared_ptr<Connection> connection;
        {
            std::lock_guard lock(mutex_);
            connection = current_;
        }
        if (!connection || !wait_for_loss(connection))
            return;
        mark_down(connection);
        connection.reset();
        announce(ConnectionState::disconnected);
        auto delay = std::chrono::duration<double, std::milli>(first_delay);
        for (;;) {
            if (!pause(std::chrono::duration_cast<std::chrono::milliseconds>(delay * jitter(random))))
                return;
            try {
                restore(Connection::to_daemon(path_));
                break;
            } catch (const std::exception&) {
                // Not back yet, or it went again while we restored: try again later.
            }
            delay = std::min<std::chrono::duration<double, std::milli>>(delay * 2, last_delay);
        }
        announce(ConnectionState::reconnected);
    }
}

bool DaemonLink::wait_for_loss(const std::shared_ptr<Connection>& connection) {
    auto retry_delay = std::chrono::milliseconds(first_delay);
    auto next_retry = Clock::now() + retry_delay;
    for (;;) {
        bool retry = false;
        {
            std::lock_guard lock(mutex_);
            if (stopping_)
                return false;
            if (current_ != connection)
                return true;
            retry = !to_make_.empty();
        }
        if (connection->broken())
            return true;
        // Ports that read or write notice a hang-up at once (EOF, EPIPE: they call lost(), which
        // writes to the pipe). For a client that is idle, the socket is looked at now and then:
        // waiting in poll() on the socket itself would wake this thread for every message that
        // arrives, a context switch per message on the hot path. Nothing is read from it here.
        pollfd wake{wake_pipe_[0], POLLIN, 0};
        auto timeout = idle_check;
        if (retry) {
            const auto until_retry = std::chrono::ceil<std::chrono::milliseconds>(next_retry - Clock::now());
            timeout = std::clamp(until_retry, std::chrono::milliseconds(0), idle_check);
        }
        if (::poll(&wake, 1, static_cast<int>(timeout.count())) > 0) {
            char bytes[64];
            while (::read(wake_pipe_[0], bytes, sizeof bytes) > 0) {
            }
        }
        pollfd socket{connection->native_handle(), POLLRDHUP, 0};
        if (::poll(&socket, 1, 0) > 0 && (socket.revents & (POLLRDHUP | POLLHUP | POLLERR)))
            return true;
        if (retry && Clock::now() >= next_retry) {
            std::vector<ConnectionSpec> left;
            {
                std::lock_guard lock(mutex_);
                left = to_make_;
            }
            try {
                retry_connections(connection, left);
            } catch (const Error&) {
                continue;  // broken: seen at the top
            }
            {
                std::lock_guard lock(mutex_);
                // Keep only those still wanted (disconnect may have run meanwhile) and not made.
                std::erase_if(to_make_, [&](const ConnectionSpec& spec) {
                    return std::none_of(left.begin(), left.end(), [&](const ConnectionSpec& other) {
                        return other.source == spec.source && other.destination == spec.destination;
                    });
                });
            }
            retry_delay = std::min(retry_delay * 2, std::chrono::milliseconds(last_delay));
            next_retry = Clock::now() + retry_delay;
        }
    }
}

std::size_t DaemonLink::retry_connections(const std::shared_ptr<Connection>& connection,
                                          std::vector<ConnectionSpec>& left) {
    std::erase_if(left, [&](const ConnectionSpec& spec) {
        const proto::Reply reply = connection->request(connect_body(spec), restore_timeout);
        if (reply.code == proto::ReplyCode::ok)
            return true;
        // Made again by someone else already (the other end's component, or a persistent entry).
        return reply.body.value("error", std::string()).find("already connected") != std::string::npos;
    });
    return left.size();
}

void DaemonLink::restore(const std::shared_ptr<Connection>& connection) {
    max_frame_.store(connection->peer_max_frame(), std::memory_order_relaxed);
    std::vector<std::shared_ptr<PortRecord>> ports;
    std::vector<ConnectionSpec> left;
    {
        std::lock_guard lock(mutex_);
        ports = ports_;
        left = connections_;
    }
    std::vector<std::uint64_t> handles;
    for (const auto& record : ports) {
        const auto reply = checked_as<proto::OpenReply>(
            connection->request(open_body(record->name, record->options), restore_timeout));
        handles.push_back(reply.handle);
    }
    // The other ends may be ports of components that are reconnecting too: give them a moment, so
    // that what was held reaches them rather than a port with no connections.
    const auto give_up = Clock::now() + wait_for_peers;
    auto delay = std::chrono::milliseconds(first_delay);
    while (retry_connections(connection, left) > 0 && Clock::now() < give_up) {
        if (!pause(delay))
            throw Error(ErrorCode::refused, "stopping");
        delay = std::min(delay * 2, std::chrono::milliseconds(500));
    }
    for (std::size_t i = 0; i < ports.size(); ++i) {
        auto& record = *ports[i];
        std::unique_lock port(record.mutex);
        if (record.closed) {
            port.unlock();
            connection->request(proto::CloseRequest{handles[i]}.encode(), restore_timeout);
            continue;
        }
        // Under the port's lock: its own writes wait, and cannot overtake what it held.
        while (!record.held.empty()) {
            const HeldMessage& message = record.held.front();
            connection->write(handles[i], record.name, message.seq, message.payload, {}, false);
            record.held_bytes -= message.payload.size();
            record.held.pop_front();
        }
        connection->flush();
        record.connection = connection;
        record.handle = handles[i];
        record.generation.fetch_add(1, std::memory_order_release);
    }
    {
        std::lock_guard lock(mutex_);
        current_ = connection;
        state_ = ConnectionState::reconnected;
        to_make_ = std::move(left);
    }
    changed_.notify_all();
}

}  // namespace plexus::detail
