#include "event_stream.hpp"

#include <algorithm>
#include <deque>

#include <spdlog/spdlog.h>
#include <boost/beast/core.hpp>
#include <boost/beast/ssl.hpp>

#include "core/message_sampler.hpp"
#include "core/wall_clock.hpp"
#include "routes.hpp"
#include "system_view.hpp"

namespace plexus::daemon::web {

namespace beast = boost::beast;

namespace {

/// The kernel's send buffer of a stream client's socket: some 20 s of events at the usual rate.
constexpr int stream_socket_buffer = 64 * 1024;

/// An events document of a port reduced to what the plot needs 20 times a second.
nlohmann::json compact_arbitration(const nlohmann::json& port) {
    nlohmann::json connections = nlohmann::json::array();
    for (const auto& connection : port.value("connections", nlohmann::json::array())) {
        const auto priority = connection.value("priority", nlohmann::json());
        nlohmann::json entry{{"source", connection.value("source", "")},
                             {"constraint", connection.value("constraint", nlohmann::json())},
                             {"constraint_value", connection.value("constraint_value", true)},
                             {"S", nullptr},
                             {"x", nullptr},
                             {"y", nullptr},
                             {"winner", false}};
        if (priority.is_object()) {
            entry["S"] = priority.value("S", 0.0);
            entry["x"] = priority.value("x", 0);
            entry["y"] = priority.value("y", 0.0);
            entry["winner"] = priority.value("winner", false);
        }
        connections.push_back(std::move(entry));
    }
    nlohmann::json compact{{"node", port.value("node", "")},
                           {"port", port.value("port", "")},
                           {"winner", port.value("winner", nlohmann::json())},
                           {"connections", std::move(connections)},
                           {"events", port.value("events", nlohmann::json::array())}};
    if (port.contains("inconsistent"))
        compact["inconsistent"] = port["inconsistent"];
    return compact;
}

}  // namespace

std::string sse_event(const std::string& name, const nlohmann::json& data) {
    // dump() writes no newline, so the data is one `data:` line as SSE wants.
    return "event: " + name +
           "\ndata: " + data.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n\n";
}

struct EventStream::Client {
    explicit Client(asio::any_io_executor executor) : wake(std::move(executor)) {}
    asio::ip::tcp::socket* socket = nullptr;  ///< closed to end a write to a client that never reads
    std::deque<std::shared_ptr<const std::string>> waiting;
    std::size_t waiting_bytes = 0;
    asio::steady_timer wake;  ///< cancelled when an event is queued or the client is dropped
    bool dropped = false;
    std::string messages_port;
    double last_message_t = 0;  ///< the newest sampled message sent to it
};

EventStream::EventStream(asio::any_io_executor executor, const HttpConfig& config, SystemView& system,
                         Routes& routes, HttpCounters& counters)
    : executor_(std::move(executor)),
      config_(config),
      system_(system),
      routes_(routes),
      counters_(counters) {}

void EventStream::drop(Client& client, bool slow) {
    if (client.dropped)
        return;
    client.dropped = true;
    if (slow) {
        counters_.count(Refused::slow_stream);
        spdlog::warn("web: dropped a stream client that did not read its events ({} bytes waiting)",
                     client.waiting_bytes);
    }
    client.waiting.clear();
    client.waiting_bytes = 0;
    client.wake.cancel();
    if (client.socket)
        client.socket->close();  // ends a write that waits for a client that never reads
}

void EventStream::queue(Client& client, const std::shared_ptr<const std::string>& text) {
    if (client.dropped)
        return;
    if (client.waiting_bytes + text->size() > config_.stream_backlog_bytes) {
        drop(client, true);
        return;
    }
    client.waiting.push_back(text);
    client.waiting_bytes += text->size();
    client.wake.cancel();
}

void EventStream::publish(const std::string& name, const nlohmann::json& data) {
    auto text = std::make_shared<const std::string>(sse_event(name, data));
    if (name == "system")
        last_system_ = text;
    for (const auto& client : clients_)
        queue(*client, text);
}

template <class Stream>
Task<void> EventStream::serve(Stream& stream, std::string messages_port) {
    auto& tcp = beast::get_lowest_layer(stream);
    static const std::string header =
        "HTTP/1.1 200 OK\r\n"
        "Content-Type: text/event-stream\r\n"
        "Cache-Control: no-store\r\n"
        "X-Content-Type-Options: nosniff\r\n"
        "Connection: close\r\n\r\n"
        // The browser reconnects by itself after this many ms when the stream breaks.
        "retry: 1000\n\n";
    // The kernel's buffer is a backlog too, and one that autotuning grows to megabytes for a client
    // that never reads: keep it small, so that what waits for a client is what is counted here.
    boost::system::error_code ignored;
    tcp.socket().set_option(asio::socket_base::send_buffer_size(stream_socket_buffer), ignored);
    auto client = std::make_shared<Client>(executor_);
    client->socket = &tcp.socket();
    client->messages_port = std::move(messages_port);
    clients_.push_back(client);
    ++counters_.stream_clients;
    queue(*client, std::make_shared<const std::string>(header));
    if (last_system_)
        queue(*client, last_system_);
    start_clocks();
    while (!client->dropped && !stopped_) {
        if (client->waiting.empty()) {
            client->wake.expires_at(asio::steady_timer::time_point::max());
            co_await client->wake.async_wait(use_nothrow);
            continue;
        }
        const auto text = client->waiting.front();
        tcp.expires_after(config_.write_timeout);
        auto [error, written] = co_await asio::async_write(stream, asio::buffer(*text), use_nothrow);
        if (error) {
            if (error == beast::error::timeout)
                drop(*client, true);
            break;
        }
        if (client->dropped)
            break;
        client->waiting.pop_front();
        client->waiting_bytes -= text->size();
        ++counters_.stream_events;
    }
    client->dropped = true;
    client->socket = nullptr;
    std::erase(clients_, client);
    --counters_.stream_clients;
}

template Task<void> EventStream::serve(beast::tcp_stream& stream, std::string messages_port);
template Task<void> EventStream::serve(beast::ssl_stream<beast::tcp_stream>& stream,
                                       std::string messages_port);

void EventStream::stop() {
    stopped_ = true;
    for (const auto& client : clients_)
        drop(*client, false);
}

void EventStream::start_clocks() {
    if (!arbitration_running_) {
        arbitration_running_ = true;
        asio::co_spawn(executor_, arbitration_clock(), asio::detached);
    }
    if (!system_running_) {
        system_running_ = true;
        asio::co_spawn(executor_, system_clock(), asio::detached);
    }
}

Task<void> EventStream::arbitration_clock() {
    asio::steady_timer timer(executor_);
    auto next = std::chrono::steady_clock::now();
    while (!clients_.empty() && !stopped_) {
        send_arbitration();
        for (const auto& client : clients_) {
            if (!client->messages_port.empty())
                send_messages(*client);
        }
        // Keeps the cadence: a tick that took long is not added to the period.
        next += config_.arbitration_period;
        const auto now = std::chrono::steady_clock::now();
        if (next < now)
            next = now;
        timer.expires_at(next);
        co_await timer.async_wait(use_nothrow);
    }
    arbitration_running_ = false;
    events_seen_.clear();
}

Task<void> EventStream::system_clock() {
    asio::steady_timer timer(executor_);
    while (!clients_.empty() && !stopped_) {
        const auto started = std::chrono::steady_clock::now();
        auto view = co_await system_.system(config_.system_period / 2);
        if (clients_.empty() || stopped_)
            break;
        publish("system", view);
        timer.expires_at(started + config_.system_period);
        co_await timer.async_wait(use_nothrow);
    }
    system_running_ = false;
    last_system_.reset();
    if (clients_.empty())
        system_.close_links();
}

void EventStream::send_arbitration() {
    const double now = wall_seconds();
    nlohmann::json ports = nlohmann::json::array();
    std::set<std::string> seen;
    for (const auto& port : system_.arbitration()) {
        auto compact = compact_arbitration(port);
        for (const auto& event : compact["events"]) {
            const std::string key = compact["node"].get<std::string>() + "\n" +
                                    compact["port"].get<std::string>() + "\n" + event.value("name", "");
            seen.insert(key);
            if (!events_seen_.contains(key)) {
                publish("event", {{"t", now},
                                  {"node", compact["node"]},
                                  {"port", compact["port"]},
                                  {"name", event.value("name", "")},
                                  {"owner", event.value("owner", "")},
                                  {"change", "set"}});
            }
        }
        ports.push_back(std::move(compact));
    }
    for (const auto& key : events_seen_) {
        if (seen.contains(key))
            continue;
        const auto first = key.find('\n');
        const auto second = key.find('\n', first + 1);
        publish("event", {{"t", now},
                          {"node", key.substr(0, first)},
                          {"port", key.substr(first + 1, second - first - 1)},
                          {"name", key.substr(second + 1)},
                          {"owner", ""},
                          {"change", "unset"}});
    }
    events_seen_ = std::move(seen);
    if (!ports.empty())
        publish("arbitration", {{"t", now}, {"ports", std::move(ports)}});
}

void EventStream::send_messages(Client& client) {
    const auto view = routes_.messages(client.messages_port);
    if (view.is_null())
        return;
    for (const auto& message : view["messages"]) {
        const double t = message.value("t", 0.0);
        if (t <= client.last_message_t)
            continue;
        client.last_message_t = t;
        nlohmann::json data = message;
        data["port"] = client.messages_port;
        data["node"] = view["node"];
        queue(client, std::make_shared<const std::string>(sse_event("message", data)));
    }
}

}  // namespace plexus::daemon::web
