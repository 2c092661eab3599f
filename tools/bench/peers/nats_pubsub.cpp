// nats-server through nats.c, core NATS (no JetStream): fire-and-forget publish, synchronous
// subscriptions. Each client is its own natsConnection, with the library's own reader and flusher threads.
#include <nats/nats.h>

#include <algorithm>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>

#include "peer_systems.hpp"
#include "server_process.hpp"

namespace plexus::bench::peers {

namespace {

constexpr int64_t flush_timeout_ms = 10'000;

struct NatsDeleter {
    void operator()(natsOptions* options) const { natsOptions_Destroy(options); }
    void operator()(natsConnection* connection) const { natsConnection_Destroy(connection); }
    void operator()(natsSubscription* subscription) const { natsSubscription_Destroy(subscription); }
    void operator()(natsMsg* message) const { natsMsg_Destroy(message); }
};
template <typename T>
using Owned = std::unique_ptr<T, NatsDeleter>;

void check(natsStatus status, const std::string& what) {
    if (status == NATS_OK)
        return;
    std::string message = "nats: " + what + ": " + natsStatus_GetText(status);
    if (const char* detail = nats_GetLastError(nullptr); detail != nullptr && *detail != '\0')
        message += std::string(" (") + detail + ")";
    throw std::runtime_error(message);
}

/// One client connection to the server on 127.0.0.1:`port`.
class NatsConnection {
public:
    /// `send_asap`: nats.c's documented option to write each publication at once instead of
    /// leaving it to the flusher thread (which otherwise adds up to about a millisecond).
    explicit NatsConnection(int port, bool send_asap = false) {
        natsOptions* options = nullptr;
        check(natsOptions_Create(&options), "create options");
        options_.reset(options);
        const std::string url = "nats://127.0.0.1:" + std::to_string(port);
        check(natsOptions_SetURL(options, url.c_str()), "set URL");
        // A reconnect would hide a connection the server closed (a slow consumer) and silently lose
        // the messages in between; the interface asks for an error instead.
        check(natsOptions_SetAllowReconnect(options, false), "disable reconnect");
        check(natsOptions_SetSendAsap(options, send_asap), "set send ASAP");
        natsConnection* connection = nullptr;
        check(natsConnection_Connect(&connection, options), "connect to " + url);
        connection_.reset(connection);
    }

    natsConnection* get() const { return connection_.get(); }

private:
    Owned<natsOptions> options_;  // declared first: destroyed after the connection
    Owned<natsConnection> connection_;
};

class NatsPublisher final : public Publisher {
public:
    NatsPublisher(int port, std::string subject, bool send_asap)
        : connection_(port, send_asap), subject_(std::move(subject)) {}

    // Buffered in the client; nats.c's flusher thread writes it out, so progress needs no sync().
    void publish(std::string_view payload) override {
        check(natsConnection_Publish(connection_.get(), subject_.c_str(), payload.data(),
                                     static_cast<int>(payload.size())),
              "publish");
    }

    // Waits for the server's PONG to a PING sent after the publications: they have all been processed.
    void sync() override { check(natsConnection_FlushTimeout(connection_.get(), flush_timeout_ms), "flush"); }

private:
    NatsConnection connection_;
    std::string subject_;
};

class NatsSubscriber final : public Subscriber {
public:
    NatsSubscriber(int port, const std::string& subject) : connection_(port) {
        natsSubscription* subscription = nullptr;
        check(natsConnection_SubscribeSync(&subscription, connection_.get(), subject.c_str()), "subscribe");
        subscription_.reset(subscription);
        // Negative limits mean "no limit" (nats.c rejects 0 with "Limits must be either > 0 or negative
        // to specify no limit"): the client library itself then never drops a message. Its reader thread
        // keeps pulling messages off the socket into this process's memory, so the server rarely sees a
        // slow consumer; if it closes one (max_pending, write_deadline), receive() reports it.
        check(natsSubscription_SetPendingLimits(subscription, -1, -1), "set pending limits");
        // The PONG to this PING proves the server has processed the SUB: the subscription is in effect.
        check(natsConnection_FlushTimeout(connection_.get(), flush_timeout_ms), "flush the subscription");
    }

    bool receive(std::string& payload, std::chrono::milliseconds timeout) override {
        natsMsg* raw = nullptr;
        const int64_t milliseconds = std::max<int64_t>(timeout.count(), 0);
        const natsStatus status = natsSubscription_NextMsg(&raw, subscription_.get(), milliseconds);
        if (status == NATS_TIMEOUT)
            return false;
        // NATS_CONNECTION_CLOSED when the server dropped this client, NATS_SLOW_CONSUMER if the
        // library had dropped messages (it cannot with the limits above).
        check(status, "receive");
        const Owned<natsMsg> message(raw);
        payload.assign(natsMsg_GetData(raw), static_cast<std::size_t>(natsMsg_GetDataLength(raw)));
        return true;
    }

private:
    NatsConnection connection_;
    Owned<natsSubscription> subscription_;  // declared after the connection: destroyed before it
};

/// Answers each request on `subject` with its own payload, from nats.c's delivery thread.
class NatsResponder final : public Responder {
public:
    NatsResponder(int port, const std::string& subject) : connection_(port, true) {
        natsSubscription* subscription = nullptr;
        check(natsConnection_Subscribe(&subscription, connection_.get(), subject.c_str(),
                                       &NatsResponder::answer, nullptr),
              "subscribe the responder");
        subscription_.reset(subscription);
        check(natsConnection_FlushTimeout(connection_.get(), flush_timeout_ms), "flush the subscription");
    }

private:
    static void answer(natsConnection* connection, natsSubscription*, natsMsg* raw, void*) {
        const Owned<natsMsg> message(raw);
        if (const char* reply = natsMsg_GetReply(raw); reply != nullptr)
            natsConnection_Publish(connection, reply, natsMsg_GetData(raw), natsMsg_GetDataLength(raw));
    }

    NatsConnection connection_;
    Owned<natsSubscription> subscription_;  // declared after the connection: destroyed before it
};

/// natsConnection_Request: publishes with a reply subject of its own and waits for the answer.
class NatsRequester final : public Requester {
public:
    NatsRequester(int port, std::string subject) : connection_(port, true), subject_(std::move(subject)) {}

    bool request(std::string_view payload, std::string& answer, std::chrono::milliseconds timeout) override {
        natsMsg* raw = nullptr;
        const natsStatus status =
            natsConnection_Request(&raw, connection_.get(), subject_.c_str(), payload.data(),
                                   static_cast<int>(payload.size()), std::max<int64_t>(timeout.count(), 1));
        if (status == NATS_TIMEOUT || status == NATS_NO_RESPONDERS)
            return false;  // NATS_NO_RESPONDERS: the responder's subscription is not in effect yet
        check(status, "request");
        const Owned<natsMsg> message(raw);
        answer.assign(natsMsg_GetData(raw), static_cast<std::size_t>(natsMsg_GetDataLength(raw)));
        return true;
    }

private:
    NatsConnection connection_;
    std::string subject_;
};

void write_config(const std::string& path, int port) {
    std::ofstream config(path, std::ios::trunc);
    // max_payload defaults to 1MB (1,048,576 bytes, headers included): a 1 MiB payload sits exactly at
    // the limit, too tight. 8MB (8 MiB in NATS units) is the largest the server accepts without a warning.
    // No JetStream and no store_dir: nothing is written to disk.
    config << "host: 127.0.0.1\n"
           << "port: " << port << "\n"
           << "max_payload: 8MB\n";
    if (!config.flush())
        throw std::runtime_error("cannot write " + path);
}

class NatsBroker final : public Broker {
public:
    explicit NatsBroker(const BrokerSetup& setup) {
        const std::string program = find_program("nats-server");
        if (program.empty())
            throw std::runtime_error("nats-server is not installed: run scripts/bench-peers-setup");
        const std::string config = setup.dir.file("nats.conf");
        server_ = start_server(
            [&](int port) {
                write_config(config, port);
                return std::vector<std::string>{program, "-c", config};
            },
            setup.dir.file("nats.log"), port_);
    }

    std::vector<pid_t> pids() const override { return {server_->pid()}; }

    std::unique_ptr<Publisher> publisher(const std::string& topic, Traffic traffic) override {
        return std::make_unique<NatsPublisher>(port_, topic, traffic == Traffic::latency);
    }

    std::unique_ptr<Subscriber> subscriber(const std::string& topic) override {
        return std::make_unique<NatsSubscriber>(port_, topic);
    }

    std::unique_ptr<Responder> responder(const std::string& service) override {
        return std::make_unique<NatsResponder>(port_, service);
    }

    std::unique_ptr<Requester> requester(const std::string& service) override {
        return std::make_unique<NatsRequester>(port_, service);
    }

private:
    int port_ = 0;
    std::unique_ptr<ChildProcess> server_;
};

}  // namespace

System nats_system() {
    return {"nats", [](const BrokerSetup& setup) { return std::make_unique<NatsBroker>(setup); }};
}

}  // namespace plexus::bench::peers
