// ZeroMQ has no broker, so the bench gives it the usual one: a proxy process (XSUB ↔ XPUB with
// zmq_proxy) between the publishers' PUB sockets and the subscribers' SUB sockets, all over TCP on
// 127.0.0.1. A message is two frames: the topic (what SUB filters on, by prefix) and the payload.
#include <zmq.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "peer_systems.hpp"

namespace plexus::bench::peers {

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr auto proxy_start_timeout = 10s;
// Long enough to hand queued messages to the proxy when a publisher goes away, bounded so that a
// proxy that is already gone cannot hang zmq_ctx_term (the default, -1, waits forever).
constexpr int publisher_linger_ms = 1000;
// A publisher blocked this long at its high-water mark means the proxy is gone: an error, not a hang.
constexpr int publisher_blocked_ms = 10'000;

[[noreturn]] void throw_zmq_error(const std::string& what) {
    throw std::runtime_error("zeromq: " + what + ": " + zmq_strerror(zmq_errno()));
}

/// A context shared by a Broker and its clients; terminated when the last of them is gone.
/// Contexts are thread safe; sockets are not, but each socket is used by one thread at a time.
using Context = std::shared_ptr<void>;

Context make_context() {
    void* context = zmq_ctx_new();
    if (context == nullptr)
        throw_zmq_error("zmq_ctx_new");
    return Context(context, [](void* c) {
        while (zmq_ctx_term(c) == -1 && zmq_errno() == EINTR) {
        }
    });
}

/// A socket that keeps its context alive until it is closed.
class Socket {
public:
    Socket(Context context, int type)
        : context_(std::move(context)), socket_(zmq_socket(context_.get(), type)) {
        if (socket_ == nullptr)
            throw_zmq_error("zmq_socket");
    }
    ~Socket() { zmq_close(socket_); }
    Socket(const Socket&) = delete;
    Socket& operator=(const Socket&) = delete;

    void* get() const { return socket_; }

    void set(int option, const void* value, std::size_t size, const char* what) {
        if (zmq_setsockopt(socket_, option, value, size) != 0)
            throw_zmq_error(what);
    }

    void set(int option, int value, const char* what) { set(option, &value, sizeof value, what); }

    void connect(const std::string& endpoint) {
        if (zmq_connect(socket_, endpoint.c_str()) != 0)
            throw_zmq_error("connect to " + endpoint);
    }

    /// Binds to a port the system chooses and returns the endpoint actually bound.
    std::string bind_any_port() {
        if (zmq_bind(socket_, "tcp://127.0.0.1:*") != 0)
            throw_zmq_error("bind");
        char endpoint[256] = {};
        std::size_t size = sizeof endpoint;
        if (zmq_getsockopt(socket_, ZMQ_LAST_ENDPOINT, endpoint, &size) != 0)
            throw_zmq_error("ZMQ_LAST_ENDPOINT");
        return endpoint;
    }

    void send(std::string_view frame, int flags) {
        while (zmq_send(socket_, frame.data(), frame.size(), flags) == -1) {
            if (zmq_errno() == EAGAIN)
                throw std::runtime_error("zeromq: send blocked past ZMQ_SNDTIMEO (is the proxy gone?)");
            if (zmq_errno() != EINTR)
                throw_zmq_error("send");
        }
    }

    /// Receives one frame (one is waiting); true if more frames of the same message follow.
    bool receive_frame(std::string& frame) {
        zmq_msg_t message;
        zmq_msg_init(&message);
        while (zmq_msg_recv(&message, socket_, 0) == -1) {
            if (zmq_errno() != EINTR) {
                zmq_msg_close(&message);
                throw_zmq_error("receive");
            }
        }
        frame.assign(static_cast<const char*>(zmq_msg_data(&message)), zmq_msg_size(&message));
        const bool more = zmq_msg_more(&message) != 0;
        zmq_msg_close(&message);
        return more;
    }

private:
    Context context_;  // declared first: outlives the socket
    void* socket_;
};

// High-water marks stay at their documented default, 1000 messages per pipe. A PUB drops silently at its
// own mark, so a publisher bursting faster than ZeroMQ's I/O thread drains the pipe loses messages before
// they reach the proxy (measured: the last 4 of 1000 published back to back, the subscriber reading along).
// No other peer's client does that: they queue or block. So publishers block at the mark instead
// (ZMQ_XPUB_NODROP, which PUB inherits from XPUB). The proxy's XPUB still drops, silently, for a subscriber
// more than its mark behind, as Mosquitto drops past max_queued_messages: that is the broker's policy, and
// the scenarios count those messages as lost.

class ZeromqPublisher final : public Publisher {
public:
    ZeromqPublisher(Context context, const std::string& proxy_input, std::string topic)
        : socket_(std::move(context), ZMQ_PUB), topic_(std::move(topic)) {
        socket_.set(ZMQ_LINGER, publisher_linger_ms, "ZMQ_LINGER");
        socket_.set(ZMQ_XPUB_NODROP, 1, "ZMQ_XPUB_NODROP");
        socket_.set(ZMQ_SNDTIMEO, publisher_blocked_ms, "ZMQ_SNDTIMEO");
        socket_.connect(proxy_input);
    }

    void publish(std::string_view payload) override {
        socket_.send(topic_, ZMQ_SNDMORE);
        socket_.send(payload, 0);
    }

    // Nothing to wait for: ZeroMQ has no flush and no acknowledgement, and its I/O thread sends
    // queued messages on its own. sync() stays the default no-op.

private:
    Socket socket_;
    std::string topic_;
};

class ZeromqSubscriber final : public Subscriber {
public:
    ZeromqSubscriber(Context context, const std::string& proxy_output, std::string topic)
        : socket_(std::move(context), ZMQ_SUB), topic_(std::move(topic)) {
        socket_.set(ZMQ_LINGER, 0, "ZMQ_LINGER");  // a SUB has nothing worth waiting for at close
        socket_.set(ZMQ_SUBSCRIBE, topic_.data(), topic_.size(), "ZMQ_SUBSCRIBE");
        // The subscription travels SUB → XPUB → proxy → XSUB → PUB in the background: messages
        // published before it arrives are dropped at the PUB (the scenarios warm up for this).
        socket_.connect(proxy_output);
    }

    bool receive(std::string& payload, std::chrono::milliseconds timeout) override {
        const auto deadline = Clock::now() + timeout;
        std::string topic;
        for (;;) {
            const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
            zmq_pollitem_t item{socket_.get(), 0, ZMQ_POLLIN, 0};
            const int ready = zmq_poll(&item, 1, std::clamp<long>(left.count(), 0, 3'600'000));
            if (ready == -1 && zmq_errno() != EINTR)
                throw_zmq_error("poll");
            if (ready <= 0) {
                if (Clock::now() >= deadline)
                    return false;
                continue;
            }
            // A multipart message arrives whole: once its first frame is here, so are the others.
            if (!socket_.receive_frame(topic))
                continue;  // a one-frame message: not ours
            bool more = socket_.receive_frame(payload);
            for (std::string extra; more;)
                more = socket_.receive_frame(extra);
            // SUB filters by prefix: "t" also lets "topic" through.
            if (topic == topic_)
                return true;
        }
    }

private:
    Socket socket_;
    std::string topic_;
};

class ZeromqBroker final : public Broker {
public:
    explicit ZeromqBroker(const BrokerSetup& setup) {
        if (setup.self.empty())
            throw std::runtime_error("zeromq: the bench's own path is needed to start the proxy");
        const std::string ready_file = setup.dir.file("zmq-proxy.json");
        proxy_ = std::make_unique<ChildProcess>(
            std::vector<std::string>{setup.self, "zmq-proxy", "--ready-file", ready_file},
            setup.dir.file("zmq-proxy.log"));
        nlohmann::json endpoints;
        const bool ready = poll_until(
                               [&] {
                                   if (!proxy_->running())
                                       return true;
                                   endpoints = nlohmann::json::parse(read_file(ready_file), nullptr, false);
                                   return !endpoints.is_discarded();
                               },
                               proxy_start_timeout) &&
                           proxy_->running() && !endpoints.is_discarded();
        if (!ready)
            throw std::runtime_error("the ZeroMQ proxy did not start:\n" + proxy_->log_tail());
        proxy_input_ = endpoints.at("xsub").get<std::string>();
        proxy_output_ = endpoints.at("xpub").get<std::string>();
        context_ = make_context();
    }

    std::vector<pid_t> pids() const override { return {proxy_->pid()}; }

    std::unique_ptr<Publisher> publisher(const std::string& topic, Traffic /*traffic*/) override {
        return std::make_unique<ZeromqPublisher>(context_, proxy_input_, topic);
    }

    std::unique_ptr<Subscriber> subscriber(const std::string& topic) override {
        return std::make_unique<ZeromqSubscriber>(context_, proxy_output_, topic);
    }

private:
    std::unique_ptr<ChildProcess> proxy_;  // declared first: the proxy outlives this context's lingering
    std::string proxy_input_;
    std::string proxy_output_;
    Context context_;
};

void write_atomically(const std::string& path, const std::string& content) {
    // Written whole under another name, then renamed: a reader never sees half a file.
    const std::string temporary = path + ".tmp";
    {
        std::ofstream out(temporary, std::ios::trunc);
        out << content;
        if (!out.flush())
            throw std::runtime_error("cannot write " + temporary);
    }
    if (std::rename(temporary.c_str(), path.c_str()) != 0)
        throw std::runtime_error("cannot rename " + temporary + " to " + path);
}

}  // namespace

int run_zmq_proxy(const std::string& ready_file) {
    try {
        const Context context = make_context();
        Socket from_publishers(context, ZMQ_XSUB);
        Socket to_subscribers(context, ZMQ_XPUB);
        const nlohmann::json endpoints = {{"xsub", from_publishers.bind_any_port()},
                                          {"xpub", to_subscribers.bind_any_port()}};
        write_atomically(ready_file, endpoints.dump());
        // Forwards messages one way and subscriptions the other, until SIGTERM ends the process.
        zmq_proxy(from_publishers.get(), to_subscribers.get(), nullptr);
        throw_zmq_error("zmq_proxy");
    } catch (const std::exception& error) {
        std::cerr << "zmq-proxy: " << error.what() << "\n";
        return 1;
    }
}

System zeromq_system() {
    return {"zeromq", [](const BrokerSetup& setup) { return std::make_unique<ZeromqBroker>(setup); }};
}

}  // namespace plexus::bench::peers
