#pragma once
// One MQTT v5 connection to the broker, kept up: connect, subscribe the --in patterns with No
// Local (the broker never sends the bridge its own publications back), and after any loss wait
// (100 ms doubling to 5 s) and connect again, resubscribing. What is published while the broker
// is away is held, up to a bound, and sent once connected; beyond the bound the oldest is dropped
// and counted.
//
// Threading: a thread of its own runs libmosquitto's loop, so every callback (on_message too)
// runs there. publish() may be called from any thread: mutex_ guards connected_ and held_, and
// libmosquitto is put in its threaded mode for the publish calls made beside its loop.
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <mosquitto.h>
#include <mqtt_protocol.h>

#include "port_counters.hpp"

namespace plexus::bridge {

struct MqttSettings {
    std::string host;
    int port = 1883;
    std::string client_id;  ///< empty: libmosquitto makes a random one
    std::optional<std::string> username;
    std::optional<std::string> password;
    std::string cafile;  ///< any of cafile/capath set: TLS
    std::string capath;
    std::string cert;
    std::string key;
    bool insecure = false;  ///< TLS without checking the server's host name
    int keepalive = 60;
    int qos = 1;
    std::vector<std::string> patterns;  ///< subscribed at every connection
    std::size_t held_limit = 1000;      ///< publications held while disconnected
};

class MqttSession {
public:
    static constexpr std::chrono::milliseconds first_retry{100};
    static constexpr std::chrono::milliseconds longest_retry{5000};

    /// Runs on the session's thread for every message of the subscribed patterns.
    using OnMessage = std::function<void(const mosquitto_message&)>;

    /// Checks the settings (TLS files readable, ...): throws UsageError when they cannot work.
    MqttSession(MqttSettings settings, OnMessage on_message);
    /// Disconnects and stops the thread.
    ~MqttSession();
    MqttSession(const MqttSession&) = delete;
    MqttSession& operator=(const MqttSession&) = delete;

    /// Starts connecting (and retrying) on the session's thread.
    void start();
    /// Publishes `payload` on `topic` at the session's QoS, or holds it while disconnected;
    /// counts it on `counters` (passed once handed to the connection, else a reason).
    void publish(const std::string& topic, std::vector<std::uint8_t> payload, bool retain,
                 PortCounters& counters);

private:
    struct Held {
        std::string topic;
        std::vector<std::uint8_t> payload;
        bool retain;
        PortCounters* counters;
    };

    void run();
    /// Connects once and runs the loop until the connection is lost or stop; why it ended.
    std::string connect_and_loop();
    /// Sends one publication now (mutex_ held).
    void send(const Held& message);
    /// Logs a connection failure when it differs from the last one logged (a broker that stays
    /// away or keeps refusing is not logged every retry).
    void note_failure(const std::string& why, std::chrono::milliseconds retry);
    bool wait_or_stop(std::chrono::milliseconds delay);

    // libmosquitto's callbacks, on the session's thread; `self` is the session.
    static void on_connect(mosquitto*, void* self, int reason, int flags, const mosquitto_property*);
    static void on_disconnect(mosquitto*, void* self, int reason, const mosquitto_property*);
    static void on_subscribe(mosquitto*, void* self, int mid, int count, const int* granted,
                             const mosquitto_property*);
    static void on_message_callback(mosquitto*, void* self, const mosquitto_message* message,
                                    const mosquitto_property*);

    MqttSettings settings_;
    OnMessage on_message_;
    mosquitto* handle_ = nullptr;
    std::string where_;

    std::mutex mutex_;
    std::condition_variable wake_;
    bool stopping_ = false;
    bool connected_ = false;  ///< CONNACK accepted and not lost since
    std::string refused_;     ///< the broker's refusal in the last CONNACK, if any
    std::deque<Held> held_;
    std::string last_failure_;  ///< session thread only

    std::thread thread_;
};

}  // namespace plexus::bridge
