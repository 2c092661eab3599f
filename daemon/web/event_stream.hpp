#pragma once
// Threading: the daemon's one thread.
//
// `/api/stream` (docs/WEB.md): Server-Sent Events to every page that watches. One clock for all of
// them: every 50 ms the arbitration of every arbitrated port (and the events set and unset since
// the last time), every second the whole system; each event is made once and queued to every
// client. A client that does not take its events is dropped once stream_backlog_bytes wait for
// it, or when one write takes longer than write_timeout: a stuck browser costs a bounded amount.

#include <cstdint>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <boost/beast/core/tcp_stream.hpp>

#include "http_config.hpp"
#include "http_counters.hpp"
#include "net/asio.hpp"

namespace plexus::daemon::web {

class Routes;
class SystemView;

class EventStream {
public:
    EventStream(asio::any_io_executor executor, const HttpConfig& config, SystemView& system, Routes& routes,
                HttpCounters& counters);

    /// Serves one client on `stream` (its request read): writes the response's header, then its
    /// events until it goes, is dropped, or stop(). `messages_port`: a port whose sampled messages
    /// it also wants ("" for none).
    /// `Stream`: beast::tcp_stream, or beast::ssl_stream of one (HTTPS).
    template <class Stream>
    Task<void> serve(Stream& stream, std::string messages_port);
    /// Ends every client's stream (the daemon stops).
    void stop();

private:
    struct Client;
    /// Queues `text` (one whole event) to `client`, dropping the client when it is too far behind.
    void queue(Client& client, const std::shared_ptr<const std::string>& text);
    void publish(const std::string& name, const nlohmann::json& data);
    /// Starts the clocks if they are not running; they stop by themselves with the last client.
    void start_clocks();
    Task<void> arbitration_clock();
    Task<void> system_clock();
    /// The arbitration event, and an `event` event for each event set or unset since the last.
    void send_arbitration();
    void send_messages(Client& client);
    void drop(Client& client, bool slow);

    asio::any_io_executor executor_;
    const HttpConfig& config_;
    SystemView& system_;
    Routes& routes_;
    HttpCounters& counters_;
    std::vector<std::shared_ptr<Client>> clients_;
    std::shared_ptr<const std::string> last_system_;  ///< for a client that joins between two
    std::set<std::string> events_seen_;               ///< "node\nport\nname" of events set now
    bool arbitration_running_ = false;
    bool system_running_ = false;
    bool stopped_ = false;
};

/// One event of the stream as text: `event: NAME\ndata: JSON\n\n`.
std::string sse_event(const std::string& name, const nlohmann::json& data);

}  // namespace plexus::daemon::web
