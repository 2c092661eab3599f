// Mosquitto through libmosquitto, MQTT QoS 0 without retain. The clients do not start libmosquitto's
// network thread (mosquitto_loop_start): each drives its own socket with mosquitto_loop* on the
// thread that uses it, so no hand-off between threads sits on the measured path.
#include <mosquitto.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <fstream>
#include <mutex>
#include <stdexcept>
#include <string>

#include "peer_systems.hpp"
#include "server_process.hpp"

namespace plexus::bench::peers {

namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr int keepalive_seconds = 60;
constexpr auto handshake_timeout = 10s;
constexpr auto sync_timeout = 10s;
constexpr int quality_of_service = 0;    // at most once, like every other system here
constexpr int subscribe_refused = 0x80;  // the SUBACK code for a refused subscription (MQTT 3.1.1)

void check(int result, const std::string& what) {
    if (result != MOSQ_ERR_SUCCESS)
        throw std::runtime_error("mosquitto: " + what + ": " + mosquitto_strerror(result));
}

/// Milliseconds left until `deadline`, rounded up so that a wait never ends just before it.
int milliseconds_until(Clock::time_point deadline) {
    const auto left = std::chrono::ceil<std::chrono::milliseconds>(deadline - Clock::now());
    return static_cast<int>(std::clamp<std::chrono::milliseconds::rep>(left.count(), 0, 3'600'000));
}

/// One MQTT connection, driven by the thread that calls it.
class MqttClient {
public:
    explicit MqttClient(int port) {
        static std::once_flag library_ready;
        std::call_once(library_ready, [] { mosquitto_lib_init(); });
        mosquitto_ = mosquitto_new(nullptr, true, this);
        if (mosquitto_ == nullptr)
            throw std::runtime_error("mosquitto: cannot create a client");
        mosquitto_connect_callback_set(mosquitto_, on_connect);
        mosquitto_subscribe_callback_set(mosquitto_, on_subscribe);
        mosquitto_message_callback_set(mosquitto_, on_message);
        check(mosquitto_int_option(mosquitto_, MOSQ_OPT_TCP_NODELAY, 1), "set TCP_NODELAY");
        check(mosquitto_connect(mosquitto_, "127.0.0.1", port, keepalive_seconds), "connect");
        // Publishing before the CONNACK is read would race the broker's accepting the session.
        run_until([&] { return connack_received_; }, "waiting for CONNACK");
        if (connack_code_ != 0)
            throw std::runtime_error(std::string("mosquitto refused the connection: ") +
                                     mosquitto_connack_string(connack_code_));
    }

    ~MqttClient() {
        mosquitto_disconnect(mosquitto_);  // best effort: a clean DISCONNECT, not an error in the log
        mosquitto_destroy(mosquitto_);
    }

    MqttClient(const MqttClient&) = delete;
    MqttClient& operator=(const MqttClient&) = delete;

    /// Subscribes and returns once the SUBACK is in, so the subscription is in effect at the broker.
    void subscribe(const std::string& topic) {
        check(mosquitto_subscribe(mosquitto_, nullptr, topic.c_str(), quality_of_service), "subscribe");
        run_until([&] { return suback_received_; }, "waiting for SUBACK");
        if (subscription_refused_)
            throw std::runtime_error("mosquitto refused the subscription to " + topic);
    }

    void publish(const std::string& topic, std::string_view payload) {
        check(mosquitto_publish(mosquitto_, nullptr, topic.c_str(), static_cast<int>(payload.size()),
                                payload.data(), quality_of_service, false),
              "publish");
        // mosquitto_publish writes until the socket would block; what is left is queued in the
        // client. Writing again now keeps the queue moving without a network thread.
        if (mosquitto_want_write(mosquitto_))
            check(mosquitto_loop_write(mosquitto_, 1), "write");
    }

    void flush() {
        const auto deadline = Clock::now() + sync_timeout;
        while (mosquitto_want_write(mosquitto_)) {
            if (Clock::now() >= deadline)
                throw std::runtime_error("mosquitto: publications still unsent after 10 s");
            // Reads as well as writes, so PINGRESPs and the like do not pile up.
            check(mosquitto_loop(mosquitto_, 10, 1), "network loop");
        }
    }

    bool receive(std::string& payload, std::chrono::milliseconds timeout) {
        const auto deadline = Clock::now() + timeout;
        while (messages_.empty()) {
            // A lost connection (e.g. the broker closed it) is an error, as the interface asks.
            check(mosquitto_loop(mosquitto_, milliseconds_until(deadline), 1), "network loop");
            if (messages_.empty() && Clock::now() >= deadline)
                return false;
        }
        payload = std::move(messages_.front());
        messages_.pop_front();
        return true;
    }

private:
    template <typename Condition>
    void run_until(Condition done, const char* what) {
        const auto deadline = Clock::now() + handshake_timeout;
        while (!done()) {
            if (Clock::now() >= deadline)
                throw std::runtime_error(std::string("mosquitto: timed out ") + what);
            check(mosquitto_loop(mosquitto_, milliseconds_until(deadline), 1), what);
        }
    }

    // The callbacks only record what arrived: an exception must not unwind through libmosquitto's C frames.
    static void on_connect(mosquitto*, void* self, int code) {
        auto& client = *static_cast<MqttClient*>(self);
        client.connack_received_ = true;
        client.connack_code_ = code;
    }

    static void on_subscribe(mosquitto*, void* self, int, int count, const int* granted) {
        auto& client = *static_cast<MqttClient*>(self);
        client.suback_received_ = true;
        client.subscription_refused_ = count < 1 || granted[0] == subscribe_refused;
    }

    static void on_message(mosquitto*, void* self, const mosquitto_message* message) {
        auto& client = *static_cast<MqttClient*>(self);
        client.messages_.emplace_back(static_cast<const char*>(message->payload),
                                      static_cast<std::size_t>(message->payloadlen));
    }

    mosquitto* mosquitto_ = nullptr;
    bool connack_received_ = false;
    int connack_code_ = 0;
    bool suback_received_ = false;
    bool subscription_refused_ = false;
    std::deque<std::string> messages_;  // read off the socket by mosquitto_loop, not yet received
};

class MosquittoPublisher final : public Publisher {
public:
    MosquittoPublisher(int port, std::string topic) : client_(port), topic_(std::move(topic)) {}
    void publish(std::string_view payload) override { client_.publish(topic_, payload); }
    void sync() override { client_.flush(); }

private:
    MqttClient client_;
    std::string topic_;
};

class MosquittoSubscriber final : public Subscriber {
public:
    MosquittoSubscriber(int port, const std::string& topic) : client_(port) { client_.subscribe(topic); }
    bool receive(std::string& payload, std::chrono::milliseconds timeout) override {
        return client_.receive(payload, timeout);
    }

private:
    MqttClient client_;
};

void write_config(const std::string& path, int port) {
    std::ofstream config(path, std::ios::trunc);
    // Defaults otherwise. Mosquitto 2.0.11 (Debian 12) queues QoS 0 messages for a subscriber that falls
    // behind without bound (100 MiB held in a smoke test); later releases count that queue against
    // max_queued_messages (1000) and drop past it, which the scenarios would count as lost.
    config << "listener " << port << " 127.0.0.1\n"
           << "allow_anonymous true\n"
           << "persistence false\n"
           << "set_tcp_nodelay true\n"
           << "log_dest stderr\n"
           << "log_type error\n"
           << "log_type warning\n";
    if (!config.flush())
        throw std::runtime_error("cannot write " + path);
}

class MosquittoBroker final : public Broker {
public:
    explicit MosquittoBroker(const BrokerSetup& setup) {
        const std::string program = find_program("mosquitto");
        if (program.empty())
            throw std::runtime_error("mosquitto is not installed: run scripts/bench-peers-setup");
        const std::string config = setup.dir.file("mosquitto.conf");
        server_ = start_server(
            [&](int port) {
                write_config(config, port);
                return std::vector<std::string>{program, "-c", config};
            },
            setup.dir.file("mosquitto.log"), port_);
    }

    std::vector<pid_t> pids() const override { return {server_->pid()}; }

    std::unique_ptr<Publisher> publisher(const std::string& topic, Traffic /*traffic*/) override {
        return std::make_unique<MosquittoPublisher>(port_, topic);
    }

    std::unique_ptr<Subscriber> subscriber(const std::string& topic) override {
        return std::make_unique<MosquittoSubscriber>(port_, topic);
    }

private:
    int port_ = 0;
    std::unique_ptr<ChildProcess> server_;
};

}  // namespace

System mosquitto_system() {
    return {"mosquitto", [](const BrokerSetup& setup) { return std::make_unique<MosquittoBroker>(setup); }};
}

}  // namespace plexus::bench::peers
