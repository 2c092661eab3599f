#pragma once
// Threading: the daemon's one thread.
//
// The endpoint's answers to GET requests, by path (docs/WEB.md): the page's files, the JSON
// views, the metrics, the login that sets the token's cookie. The live stream is event_stream's.

#include <memory>
#include <string>

#include "control/control_host.hpp"
#include "core/message_sampler.hpp"
#include "http_counters.hpp"
#include "net/asio.hpp"
#include "net/shm_region.hpp"
#include "system_view.hpp"
#include "web_types.hpp"

namespace plexus::daemon::web {

class Access;

class Routes {
public:
    Routes(ControlHost& host, const ShmUsage& shm, SystemView& system, const HttpCounters& counters,
           const Access& access);

    /// The answer to a GET (or HEAD) of `request`; counts nothing (the server counts refusals).
    Task<WebResponse> answer(WebRequest request);

    /// The sampler of `port` (a port of this daemon), made if needed and marked as asked for now;
    /// null when there is no such port here. Samplers nobody asked for a minute are dropped.
    MessageSampler* watch_messages(const std::string& port);
    /// `{"port", "node", "messages": [...]}`, or null when the port is not here.
    nlohmann::json messages(const std::string& port);

private:
    /// Drops the samplers nobody asked for lately, so an idle port costs nothing again.
    void forget_old_samplers();

    ControlHost& host_;
    const ShmUsage& shm_;
    SystemView& system_;
    const HttpCounters& counters_;
    const Access& access_;
};

/// A JSON response with `status` and `{"error": why}`.
WebResponse error_response(unsigned status, const std::string& why);

}  // namespace plexus::daemon::web
