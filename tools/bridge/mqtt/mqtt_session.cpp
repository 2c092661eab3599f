#include "mqtt_session.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <mutex>

#include <spdlog/spdlog.h>

#include "mapping.hpp"

namespace plexus::bridge {

namespace {
void init_library_once() {
    static std::once_flag once;
    std::call_once(once, [] { mosquitto_lib_init(); });
}

// For MOSQ_ERR_ERRNO, libmosquitto 2 already says strerror(errno) ("Connection refused").
std::string error_text(int rc) {
    return mosquitto_strerror(rc);
}
}  // namespace

MqttSession::MqttSession(MqttSettings settings, OnMessage on_message)
    : settings_(std::move(settings)),
      on_message_(std::move(on_message)),
      where_(settings_.host + ":" + std::to_string(settings_.port)) {
    init_library_once();
    // Clean start: the subscriptions are made again at every connection, so the broker need not
    // keep a session for a bridge that may never come back.
    handle_ = mosquitto_new(settings_.client_id.empty() ? nullptr : settings_.client_id.c_str(), true, this);
    if (handle_ == nullptr)
        throw UsageError("mqtt: cannot make a client (client id '" + settings_.client_id + "')");
    // MQTT v5 for No Local: without it the bridge's own publications on topics it subscribes come back.
    mosquitto_int_option(handle_, MOSQ_OPT_PROTOCOL_VERSION, MQTT_PROTOCOL_V5);
    // Small messages at once: with Nagle's algorithm a small publication waits for the broker's
    // delayed ACK, 40 ms on Linux (measured: 64 B one-way 44 ms without this).
    mosquitto_int_option(handle_, MOSQ_OPT_TCP_NODELAY, 1);
    mosquitto_threaded_set(handle_, true);
    if (settings_.username || settings_.password) {
        const auto rc =
            mosquitto_username_pw_set(handle_, settings_.username ? settings_.username->c_str() : nullptr,
                                      settings_.password ? settings_.password->c_str() : nullptr);
        if (rc != MOSQ_ERR_SUCCESS)
            throw UsageError("mqtt: --username/--password: " + error_text(rc));
    }
    if (!settings_.cafile.empty() || !settings_.capath.empty()) {
        const auto opt = [](const std::string& s) { return s.empty() ? nullptr : s.c_str(); };
        const auto rc = mosquitto_tls_set(handle_, opt(settings_.cafile), opt(settings_.capath),
                                          opt(settings_.cert), opt(settings_.key), nullptr);
        if (rc != MOSQ_ERR_SUCCESS)
            throw UsageError("mqtt: --cafile/--capath/--cert/--key: " + error_text(rc) +
                             " (are the files there and readable?)");
        mosquitto_tls_insecure_set(handle_, settings_.insecure);
    } else if (!settings_.cert.empty() || !settings_.key.empty()) {
        throw UsageError("mqtt: --cert and --key need --cafile or --capath (TLS)");
    }
    mosquitto_connect_v5_callback_set(handle_, &MqttSession::on_connect);
    mosquitto_disconnect_v5_callback_set(handle_, &MqttSession::on_disconnect);
    mosquitto_subscribe_v5_callback_set(handle_, &MqttSession::on_subscribe);
    mosquitto_message_v5_callback_set(handle_, &MqttSession::on_message_callback);
}

MqttSession::~MqttSession() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable())
        thread_.join();
    mosquitto_destroy(handle_);
}

void MqttSession::start() {
    thread_ = std::thread([this] { run(); });
}

bool MqttSession::wait_or_stop(std::chrono::milliseconds delay) {
    std::unique_lock lock(mutex_);
    return wake_.wait_for(lock, delay, [this] { return stopping_; });
}

void MqttSession::run() {
    auto retry = first_retry;
    for (;;) {
        {
            std::lock_guard lock(mutex_);
            if (stopping_)
                break;
            refused_.clear();
        }
        const auto why = connect_and_loop();
        bool was_connected = false;
        std::string refused;
        {
            std::lock_guard lock(mutex_);
            was_connected = connected_;
            connected_ = false;
            refused = refused_;
            if (stopping_)
                break;
        }
        // A connection that was accepted starts the back-off again: the broker was there.
        if (was_connected)
            retry = first_retry;
        note_failure(refused.empty() ? why : "refused: " + refused, retry);
        if (wait_or_stop(retry))
            break;
        retry = std::min(retry * 2, longest_retry);
    }
    mosquitto_disconnect(handle_);
}

std::string MqttSession::connect_and_loop() {
    auto rc = mosquitto_connect(handle_, settings_.host.c_str(), settings_.port, settings_.keepalive);
    if (rc != MOSQ_ERR_SUCCESS)
        return "cannot connect: " + error_text(rc);
    // mosquitto_loop waits up to 100 ms for the socket, so a stop is seen that quickly.
    for (;;) {
        {
            std::lock_guard lock(mutex_);
            if (stopping_)
                return "stopping";
        }
        rc = mosquitto_loop(handle_, 100, 1);
        if (rc != MOSQ_ERR_SUCCESS)
            return "connection lost: " + error_text(rc);
    }
}

void MqttSession::note_failure(const std::string& why, std::chrono::milliseconds retry) {
    if (why == last_failure_) {
        spdlog::debug("mqtt broker {}: {}; retrying in {} ms", where_, why, retry.count());
        return;
    }
    last_failure_ = why;
    spdlog::warn(
        "mqtt broker {}: {}; retrying with back-off ({} ms doubling to {} ms), publications held "
        "meanwhile up to {}",
        where_, why, retry.count(), longest_retry.count(), settings_.held_limit);
}

void MqttSession::on_connect(mosquitto* handle, void* self_pointer, int reason, int,
                             const mosquitto_property*) {
    auto& self = *static_cast<MqttSession*>(self_pointer);
    if (reason != 0) {
        std::lock_guard lock(self.mutex_);
        self.refused_ = mosquitto_reason_string(reason);
        return;
    }
    self.last_failure_.clear();
    spdlog::info("mqtt broker {}: connected", self.where_);
    if (!self.settings_.patterns.empty()) {
        std::vector<char*> patterns;
        for (auto& pattern : self.settings_.patterns)
            patterns.push_back(pattern.data());
        const auto rc =
            mosquitto_subscribe_multiple(handle, nullptr, static_cast<int>(patterns.size()), patterns.data(),
                                         self.settings_.qos, MQTT_SUB_OPT_NO_LOCAL, nullptr);
        if (rc != MOSQ_ERR_SUCCESS)
            spdlog::error("mqtt broker {}: cannot subscribe: {}", self.where_, error_text(rc));
    }
    std::lock_guard lock(self.mutex_);
    self.connected_ = true;
    std::size_t sent = 0;
    while (!self.held_.empty()) {
        self.send(self.held_.front());
        self.held_.pop_front();
        ++sent;
    }
    if (sent > 0)
        spdlog::info("mqtt broker {}: sent {} publications held while disconnected", self.where_, sent);
}

void MqttSession::on_disconnect(mosquitto*, void* self_pointer, int, const mosquitto_property*) {
    auto& self = *static_cast<MqttSession*>(self_pointer);
    std::lock_guard lock(self.mutex_);
    self.connected_ = false;
}

void MqttSession::on_subscribe(mosquitto*, void* self_pointer, int, int count, const int* granted,
                               const mosquitto_property*) {
    auto& self = *static_cast<MqttSession*>(self_pointer);
    std::string refused;
    for (int i = 0; i < count && i < static_cast<int>(self.settings_.patterns.size()); ++i) {
        if (granted[i] >= 0x80)
            refused += " " + self.settings_.patterns[i] + " (" + mosquitto_reason_string(granted[i]) + ")";
    }
    if (refused.empty())
        spdlog::info("mqtt broker {}: subscribed to {} patterns", self.where_, count);
    else
        spdlog::error("mqtt broker {}: the broker refused to subscribe:{}", self.where_, refused);
}

void MqttSession::on_message_callback(mosquitto*, void* self_pointer, const mosquitto_message* message,
                                      const mosquitto_property*) {
    static_cast<MqttSession*>(self_pointer)->on_message_(*message);
}

void MqttSession::publish(const std::string& topic, std::vector<std::uint8_t> payload, bool retain,
                          PortCounters& counters) {
    std::lock_guard lock(mutex_);
    if (connected_) {
        send({topic, std::move(payload), retain, &counters});
        return;
    }
    // The oldest goes first: what a reader of the topic wants after an outage is the newest.
    if (held_.size() >= settings_.held_limit) {
        held_.front().counters->dropped("disconnected_overflow",
                                        "the broker is away and " + std::to_string(settings_.held_limit) +
                                            " publications are held already; the oldest was dropped");
        held_.pop_front();
    }
    held_.push_back({topic, std::move(payload), retain, &counters});
}

void MqttSession::send(const Held& message) {
    const auto rc = mosquitto_publish_v5(handle_, nullptr, message.topic.c_str(),
                                         static_cast<int>(message.payload.size()), message.payload.data(),
                                         settings_.qos, message.retain, nullptr);
    if (rc == MOSQ_ERR_SUCCESS)
        message.counters->passed();
    else
        message.counters->dropped("not_delivered", "publishing on " + message.topic + ": " + error_text(rc));
}

}  // namespace plexus::bridge
