#include "mqtt_link.hpp"

#include <atomic>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <stdexcept>
#include <thread>

#include <mosquitto.h>
#include <mqtt_protocol.h>

namespace plexus::bench::bridges {

namespace {

class MqttLink final : public Link {
public:
    MqttLink(const std::string& host, int port, std::string out, std::string in, int qos)
        : out_(std::move(out)), in_(std::move(in)), qos_(qos) {
        mosquitto_lib_init();
        client_ = mosquitto_new(nullptr, true, this);
        if (!client_)
            throw std::runtime_error("mosquitto_new failed");
        mosquitto_int_option(client_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V5);
        mosquitto_int_option(client_, MOSQ_OPT_TCP_NODELAY, 1);  // as the bridge and the peers bench
        mosquitto_connect_v5_callback_set(
            client_, [](mosquitto* client, void* self, int rc, int, const mosquitto_property*) {
                auto* link = static_cast<MqttLink*>(self);
                if (rc == 0)
                    mosquitto_subscribe_v5(client, nullptr, link->in_.c_str(), link->qos_, 0, nullptr);
            });
        mosquitto_subscribe_v5_callback_set(
            client_, [](mosquitto*, void* self, int, int, const int*, const mosquitto_property*) {
                static_cast<MqttLink*>(self)->subscribed_ = true;
            });
        mosquitto_message_v5_callback_set(
            client_, [](mosquitto*, void* self, const mosquitto_message* message, const mosquitto_property*) {
                auto* link = static_cast<MqttLink*>(self);
                const auto* bytes = static_cast<const std::uint8_t*>(message->payload);
                {
                    std::lock_guard lock(link->mutex_);
                    link->received_.emplace_back(bytes, bytes + message->payloadlen);
                }
                link->arrived_.notify_one();
            });
        // The broker was started just before: retry while it comes up.
        const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
        for (int rc; (rc = mosquitto_connect(client_, host.c_str(), port, 30)) != MOSQ_ERR_SUCCESS;) {
            if (std::chrono::steady_clock::now() > deadline)
                throw std::runtime_error("cannot connect to the MQTT broker at " + host + ":" +
                                         std::to_string(port) + ": " + mosquitto_strerror(rc));
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
        mosquitto_loop_start(client_);
    }
    ~MqttLink() override {
        mosquitto_disconnect(client_);
        mosquitto_loop_stop(client_, false);
        mosquitto_destroy(client_);
    }

    void publish(std::span<const std::uint8_t> payload) override {
        const int rc = mosquitto_publish_v5(client_, nullptr, out_.c_str(), static_cast<int>(payload.size()),
                                            payload.data(), qos_, false, nullptr);
        if (rc != MOSQ_ERR_SUCCESS)
            throw std::runtime_error(std::string("mosquitto_publish: ") + mosquitto_strerror(rc));
    }

    std::optional<std::vector<std::uint8_t>> receive(std::chrono::milliseconds timeout) override {
        std::unique_lock lock(mutex_);
        if (!arrived_.wait_for(lock, timeout, [this] { return !received_.empty(); }))
            return std::nullopt;
        auto out = std::move(received_.front());
        received_.pop_front();
        return out;
    }

    bool ready() override { return subscribed_.load(); }

private:
    std::string out_;
    std::string in_;
    int qos_;
    mosquitto* client_ = nullptr;
    std::atomic<bool> subscribed_{false};
    std::mutex mutex_;
    std::condition_variable arrived_;
    std::deque<std::vector<std::uint8_t>> received_;
};

}  // namespace

std::unique_ptr<Link> make_mqtt_link(const std::string& host, int port, const std::string& out,
                                     const std::string& in, int qos) {
    return std::make_unique<MqttLink>(host, port, out, in, qos);
}

}  // namespace plexus::bench::bridges
