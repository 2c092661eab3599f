#include "routes.hpp"

#include "access.hpp"
#include "core/router.hpp"
#include "inspect/events_view.hpp"
#include "inspect/stats_view.hpp"
#include "metrics.hpp"
#include "page_files.hpp"

namespace plexus::daemon::web {

namespace {

/// How long a sampler lives after the last request for it.
constexpr auto sampler_lifetime = std::chrono::minutes(1);
/// How long /api/system waits for the other daemons.
constexpr auto system_wait = std::chrono::milliseconds(1500);

WebResponse json_response(const nlohmann::json& body) {
    WebResponse response;
    // Replace, not throw: a monitor's last_error or a payload may hold bytes that are not UTF-8.
    response.body = body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
    response.headers.emplace_back("Cache-Control", "no-store");
    return response;
}

}  // namespace

WebResponse error_response(unsigned status, const std::string& why) {
    WebResponse response = json_response({{"error", why}});
    response.status = status;
    return response;
}

Routes::Routes(ControlHost& host, const ShmUsage& shm, SystemView& system, const HttpCounters& counters,
               const Access& access)
    : host_(host), shm_(shm), system_(system), counters_(counters), access_(access) {}

Task<WebResponse> Routes::answer(WebRequest request) {
    const std::string& path = request.path;
    if (path == "/" || path == "/index.html")
        request.path = "/static/index.html";
    if (request.path.starts_with("/static/")) {
        const PageFile* file = find_page_file(request.path);
        if (!file)
            co_return error_response(404, "no such file: " + request.path);
        WebResponse response;
        response.content_type = std::string(file->content_type);
        response.body = std::string(file->bytes);
        co_return response;
    }
    if (path == "/login") {
        // The person enters the token once; the cookie carries it from then on. A wrong token
        // sets nothing and says so.
        const std::string token = query_value(request.query, "token");
        if (!access_.token_ok(token))
            co_return error_response(
                401, "that is not this deployment's web token (plexus web --token prints it)");
        WebResponse response;
        response.status = 303;
        response.content_type = "text/plain";
        response.headers.emplace_back("Location", "/");
        // Over HTTPS the browser sends the cookie only over HTTPS (Secure).
        response.headers.emplace_back("Set-Cookie", "plexus_token=" + token +
                                                        "; HttpOnly; SameSite=Strict; Path=/" +
                                                        (host_.http_tls() ? "; Secure" : ""));
        co_return response;
    }
    if (path == "/api/node") {
        const auto& config = host_.config();
        co_return json_response({{"node", config.node},
                                 {"address", host_.address()},
                                 {"names", config.names.text()},
                                 {"http", host_.http_address()}});
    }
    if (path == "/api/stats") {
        const std::string port = query_value(request.query, "port");
        if (!port.empty() && !host_.router().find(port))
            co_return error_response(404, "port " + port + " is not on node '" + host_.config().node + "'");
        co_return json_response(inspect::stats_view(host_, shm_, port));
    }
    if (path == "/api/events") {
        const std::string name = query_value(request.query, "port");
        auto port = host_.router().find(name);
        if (!port)
            co_return error_response(404, "port " + name + " is not on node '" + host_.config().node + "'");
        co_return json_response(inspect::events_view(*port, query_value(request.query, "check") == "true",
                                                     host_.config().node, host_.clock().now()));
    }
    if (path == "/api/messages") {
        const std::string port = query_value(request.query, "port");
        auto view = messages(port);
        if (view.is_null())
            co_return error_response(404, "port " + port + " is not on node '" + host_.config().node + "'");
        co_return json_response(view);
    }
    if (path == "/api/names")
        co_return json_response(co_await system_.names());
    if (path == "/api/system")
        co_return json_response(co_await system_.system(system_wait));
    if (path == "/metrics") {
        WebResponse response;
        response.content_type = "text/plain; version=0.0.4; charset=utf-8";
        response.body = metrics_text(inspect::stats_view(host_, shm_, ""), counters_);
        co_return response;
    }
    co_return error_response(404, "no such path: " + path + " (docs/WEB.md lists them)");
}

void Routes::forget_old_samplers() {
    const auto now = MessageSampler::Clock::now();
    for (const auto& [name, port] : host_.router().ports()) {
        if (port->sampler && now - port->sampler->last_asked > sampler_lifetime)
            port->sampler.reset();
    }
}

MessageSampler* Routes::watch_messages(const std::string& name) {
    forget_old_samplers();
    auto port = host_.router().find(name);
    if (!port)
        return nullptr;
    if (!port->sampler)
        port->sampler = std::make_unique<MessageSampler>();
    port->sampler->last_asked = MessageSampler::Clock::now();
    return port->sampler.get();
}

nlohmann::json Routes::messages(const std::string& port) {
    const MessageSampler* sampler = watch_messages(port);
    if (!sampler)
        return nullptr;
    return {{"port", port}, {"node", host_.config().node}, {"messages", sampler->samples()}};
}

}  // namespace plexus::daemon::web
