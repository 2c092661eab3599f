// Redis pub/sub through hiredis (0.14), synchronous contexts: PUBLISH on one connection, SUBSCRIBE on
// another. Payloads go as binary-safe bulk strings (%b), so any byte, NUL included, passes.
#include <hiredis/hiredis.h>
#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <memory>
#include <stdexcept>
#include <string>

#include "peer_systems.hpp"
#include "server_process.hpp"

namespace plexus::bench::peers {

namespace {

using Clock = std::chrono::steady_clock;

// Replies read in one go by a pipelining publisher; they are small integers, so the server holds
// little for it in between.
constexpr int max_unread_replies = 1024;

struct RedisDeleter {
    void operator()(redisContext* context) const { redisFree(context); }
    void operator()(redisReply* reply) const { freeReplyObject(reply); }
};
using Connection = std::unique_ptr<redisContext, RedisDeleter>;
using Reply = std::unique_ptr<redisReply, RedisDeleter>;

[[noreturn]] void throw_redis_error(const redisContext& context, const std::string& what) {
    throw std::runtime_error("redis: " + what + ": " + (context.err != 0 ? context.errstr : "unknown error"));
}

Connection connect(int port) {
    // hiredis sets TCP_NODELAY on the connections it opens.
    Connection connection(redisConnect("127.0.0.1", port));
    if (!connection)
        throw std::runtime_error("redis: cannot allocate a connection");
    if (connection->err != 0)
        throw_redis_error(*connection, "connect to port " + std::to_string(port));
    return connection;
}

/// The next reply, waiting for it as long as needed.
Reply next_reply(redisContext& context, const char* what) {
    void* reply = nullptr;
    if (redisGetReply(&context, &reply) != REDIS_OK)
        throw_redis_error(context, what);
    return Reply(static_cast<redisReply*>(reply));
}

bool is_string(const redisReply& reply, const char* text) {
    return (reply.type == REDIS_REPLY_STRING || reply.type == REDIS_REPLY_STATUS) &&
           reply.str == std::string(text);
}

class RedisPublisher final : public Publisher {
public:
    RedisPublisher(int port, std::string channel)
        : connection_(connect(port)), channel_(std::move(channel)) {}

    // hiredis's documented pipelining: commands go out at once, their replies are read later in batches,
    // so a publisher does not wait a round trip per message. A faster mode than redisCommand's
    // one-reply-per-command, and what a throughput-minded Redis user would write.
    void publish(std::string_view payload) override {
        if (redisAppendCommand(connection_.get(), "PUBLISH %s %b", channel_.c_str(), payload.data(),
                               payload.size()) != REDIS_OK)
            throw_redis_error(*connection_, "PUBLISH");
        for (int done = 0; done == 0;) {
            if (redisBufferWrite(connection_.get(), &done) != REDIS_OK)
                throw_redis_error(*connection_, "write PUBLISH");
        }
        if (++unread_replies_ >= max_unread_replies)
            read_replies();
    }

    void sync() override { read_replies(); }

private:
    void read_replies() {
        for (; unread_replies_ > 0; --unread_replies_) {
            const Reply reply = next_reply(*connection_, "read a PUBLISH reply");
            if (reply->type == REDIS_REPLY_ERROR)
                throw std::runtime_error("redis refused PUBLISH: " + std::string(reply->str, reply->len));
        }
    }

    Connection connection_;
    std::string channel_;
    int unread_replies_ = 0;
};

class RedisSubscriber final : public Subscriber {
public:
    RedisSubscriber(int port, const std::string& channel) : connection_(connect(port)) {
        // redisCommand sends SUBSCRIBE and reads its confirmation: the subscription is then in effect.
        const Reply confirmation(static_cast<redisReply*>(
            redisCommand(connection_.get(), "SUBSCRIBE %b", channel.data(), channel.size())));
        if (!confirmation)
            throw_redis_error(*connection_, "SUBSCRIBE");
        if (confirmation->type != REDIS_REPLY_ARRAY || confirmation->elements < 1 ||
            !is_string(*confirmation->element[0], "subscribe"))
            throw std::runtime_error("redis: unexpected reply to SUBSCRIBE " + channel);
    }

    bool receive(std::string& payload, std::chrono::milliseconds timeout) override {
        const auto deadline = Clock::now() + timeout;
        for (;;) {
            Reply reply = buffered_reply();
            if (!reply) {
                // A blocking hiredis context treats a socket timeout as a fatal error, so the wait
                // happens here, in poll(), and hiredis reads only once there is something to read.
                if (!wait_readable(deadline))
                    return false;
                reply = next_reply(*connection_, "receive");
            }
            // ["message", channel, payload]; anything else (e.g. another confirmation) is skipped.
            if (reply->type == REDIS_REPLY_ARRAY && reply->elements == 3 &&
                is_string(*reply->element[0], "message")) {
                const redisReply& body = *reply->element[2];
                payload.assign(body.str, body.len);
                return true;
            }
        }
    }

private:
    /// A reply hiredis has already read off the socket, without any I/O; null if none.
    Reply buffered_reply() {
        void* reply = nullptr;
        if (redisGetReplyFromReader(connection_.get(), &reply) != REDIS_OK)
            throw_redis_error(*connection_, "parse a reply");
        return Reply(static_cast<redisReply*>(reply));
    }

    /// True once the socket is readable (data, or a closed connection for hiredis to report); false at
    /// `deadline`.
    bool wait_readable(Clock::time_point deadline) {
        for (;;) {
            const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
            pollfd socket{connection_->fd, POLLIN, 0};
            const int ready =
                ::poll(&socket, 1, static_cast<int>(std::clamp<long>(left.count(), 0, 3'600'000)));
            if (ready > 0)
                return true;
            if (ready < 0 && errno != EINTR)
                throw std::runtime_error("redis: poll failed");
            if (Clock::now() >= deadline)
                return false;
        }
    }

    Connection connection_;
};

class RedisBroker final : public Broker {
public:
    explicit RedisBroker(const BrokerSetup& setup) {
        const std::string program = find_program("redis-server");
        if (program.empty())
            throw std::runtime_error("redis-server is not installed: run scripts/bench-peers-setup");
        const std::string directory = setup.dir.path();
        server_ = start_server(
            [&](int port) {
                // --save "" and --appendonly no: nothing persistent. --dir keeps anything Redis might
                // still write in the bench's temporary directory rather than the current one. The default
                // client-output-buffer-limit stays: a subscriber more than 32 MB behind (or 8 MB for 60 s)
                // is disconnected, which its receive() reports.
                return std::vector<std::string>{program,
                                                "--port",
                                                std::to_string(port),
                                                "--bind",
                                                "127.0.0.1",
                                                "--save",
                                                "",
                                                "--appendonly",
                                                "no",
                                                "--daemonize",
                                                "no",
                                                "--protected-mode",
                                                "no",
                                                "--dir",
                                                directory};
            },
            setup.dir.file("redis.log"), port_);
    }

    std::vector<pid_t> pids() const override { return {server_->pid()}; }

    std::unique_ptr<Publisher> publisher(const std::string& topic, Traffic /*traffic*/) override {
        return std::make_unique<RedisPublisher>(port_, topic);
    }

    std::unique_ptr<Subscriber> subscriber(const std::string& topic) override {
        return std::make_unique<RedisSubscriber>(port_, topic);
    }

private:
    int port_ = 0;
    std::unique_ptr<ChildProcess> server_;
};

}  // namespace

System redis_system() {
    return {"redis", [](const BrokerSetup& setup) { return std::make_unique<RedisBroker>(setup); }};
}

}  // namespace plexus::bench::peers
