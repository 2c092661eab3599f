#include "http_server.hpp"

#include <spdlog/spdlog.h>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/ssl.hpp>

#include "plexus/proto/certificates.hpp"
#include "plexus/proto/identity.hpp"

namespace plexus::daemon::web {

namespace beast = boost::beast;
namespace http = beast::http;

namespace {

/// 503 answers written at once, beyond which a connection over the limit is just closed.
constexpr std::size_t most_refusing = 64;

/// What the endpoint says on every response: the views are read-only and same-origin only.
void add_common_headers(http::response<http::string_body>& response) {
    response.set(http::field::server, "plexusd");
    response.set("X-Content-Type-Options", "nosniff");
    response.set("X-Frame-Options", "DENY");
    response.set("Referrer-Policy", "no-referrer");
    // The page's own scripts only; its libraries set element styles, hence 'unsafe-inline' styles.
    response.set("Content-Security-Policy",
                 "default-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
                 "connect-src 'self'; frame-ancestors 'none'");
}

http::response<http::string_body> to_beast(const WebResponse& answer, unsigned version, bool keep_alive,
                                           bool head) {
    http::response<http::string_body> response{static_cast<http::status>(answer.status), version};
    add_common_headers(response);
    response.set(http::field::content_type, answer.content_type);
    for (const auto& [name, value] : answer.headers)
        response.set(name, value);
    response.keep_alive(keep_alive);
    response.body() = answer.body;
    response.prepare_payload();
    if (head) {
        response.body().clear();
        response.content_length(answer.body.size());
    }
    return response;
}

Refused refusal_of_read_error(const beast::error_code& error) {
    if (error == http::error::header_limit || error == http::error::buffer_overflow)
        return Refused::header_too_large;
    if (error == http::error::unexpected_body)
        return Refused::body;
    if (error == beast::error::timeout)
        return Refused::read_timeout;
    return Refused::bad_request;
}

}  // namespace

HttpServer::HttpServer(asio::io_context& io, HttpConfig config, ControlHost& host, const ShmUsage& shm)
    : io_(io),
      config_(std::move(config)),
      host_(host),
      acceptor_(io),
      access_(host.config().secret, host.config().insecure),
      system_(io.get_executor(), host, shm),
      routes_(host, shm, system_, counters_, access_),
      stream_(io.get_executor(), config_, system_, routes_, counters_) {}

HttpServer::~HttpServer() = default;

proto::Status HttpServer::bind() {
    const auto& where = *config_.listen;
    boost::system::error_code ec;
    auto address = asio::ip::make_address(where.host, ec);
    if (ec)
        return proto::Error{"--http host '" + where.host + "' is not an IP address"};
    asio::ip::tcp::endpoint endpoint(address, where.port);
    acceptor_.open(endpoint.protocol(), ec);
    if (!ec)
        acceptor_.set_option(asio::socket_base::reuse_address(true), ec);
    if (!ec)
        acceptor_.bind(endpoint, ec);
    if (!ec)
        acceptor_.listen(asio::socket_base::max_listen_connections, ec);
    if (ec)
        return proto::Error{"cannot serve the web page on " + where.text() + ": " + ec.message()};
    // Beyond loopback with the secret, the page is HTTPS: the web token and the views never cross
    // the network in clear. With an identity, with the node's certificate (browsers that trust the
    // CA take it); with the secret alone, with a self-signed one made now, whose fingerprint
    // `plexus web` and the log show for a person to compare before accepting it.
    const auto& secret = host_.config().secret;
    if (secret && !address.is_loopback()) {
        try {
            tls_ = std::make_unique<asio::ssl::context>(
                secret->identity()
                    ? proto::new_web_tls_context(*secret->identity())
                    : proto::new_self_signed_web_tls_context(address.to_string(), fingerprint_));
        } catch (const std::exception& e) {
            return proto::Error{std::string("cannot serve the web page over HTTPS: ") + e.what()};
        }
    }
    return proto::Ok{};
}

std::string HttpServer::address() const {
    boost::system::error_code ec;
    const auto local = acceptor_.local_endpoint(ec);
    if (ec)
        return "";
    const auto host = local.address();
    const std::string text = host.is_v6() ? "[" + host.to_string() + "]" : host.to_string();
    return text + ":" + std::to_string(local.port());
}

void HttpServer::start() {
    asio::co_spawn(io_, accept(), asio::detached);
}

void HttpServer::stop() {
    stopped_ = true;
    boost::system::error_code ignored;
    acceptor_.close(ignored);
    stream_.stop();
    system_.close_links();
}

Task<void> HttpServer::accept() {
    while (!stopped_) {
        auto [error, socket] = co_await acceptor_.async_accept(use_nothrow);
        if (error) {
            if (error == asio::error::operation_aborted || stopped_)
                co_return;
            // Out of descriptors, most likely: pause rather than spin.
            spdlog::warn("web: accept failed: {}", error.message());
            asio::steady_timer pause(io_, std::chrono::milliseconds(100));
            co_await pause.async_wait(use_nothrow);
            continue;
        }
        ++counters_.connections_accepted;
        if (counters_.connections_open >= config_.max_connections) {
            counters_.count(Refused::too_many_connections);
            if (refusing_ < most_refusing && !tls_)  // an HTTPS client would read a plain 503 as garbage
                asio::co_spawn(io_, refuse_busy(std::move(socket)), asio::detached);
            continue;
        }
        asio::co_spawn(io_, serve(std::move(socket)), asio::detached);
    }
}

Task<void> HttpServer::refuse_busy(asio::ip::tcp::socket socket) {
    ++refusing_;
    beast::tcp_stream stream(std::move(socket));
    auto response = to_beast(error_response(503, "too many connections to this web endpoint; try again"), 11,
                             false, false);
    stream.expires_after(std::chrono::seconds(1));
    co_await http::async_write(stream, response, use_nothrow);
    --refusing_;
}

Task<void> HttpServer::serve(asio::ip::tcp::socket socket) {
    ++counters_.connections_open;
    boost::system::error_code ec;
    const auto remote = socket.remote_endpoint(ec).address();
    if (tls_) {
        beast::ssl_stream<beast::tcp_stream> stream(beast::tcp_stream(std::move(socket)), *tls_);
        beast::get_lowest_layer(stream).expires_after(config_.read_timeout);
        auto [handshake_error] = co_await stream.async_handshake(asio::ssl::stream_base::server, use_nothrow);
        if (!handshake_error) {
            co_await answer_requests(stream, remote);
        } else {
            counters_.count(Refused::bad_request);
            spdlog::debug("web: TLS handshake from {} failed: {}", remote.to_string(),
                          handshake_error.message());
        }
        // No close_notify: the response said how long it is, and the socket closes next.
        beast::get_lowest_layer(stream).socket().shutdown(asio::ip::tcp::socket::shutdown_send, ec);
        beast::get_lowest_layer(stream).close();
    } else {
        beast::tcp_stream stream(std::move(socket));
        co_await answer_requests(stream, remote);
        stream.socket().shutdown(asio::ip::tcp::socket::shutdown_send, ec);
        stream.close();
    }
    --counters_.connections_open;
}

template <class Stream>
Task<void> HttpServer::answer_requests(Stream& stream, const asio::ip::address& remote) {
    // Room for the largest header the parser accepts, and no more.
    beast::flat_buffer buffer(config_.header_limit + 1024);
    for (;;) {
        http::request_parser<http::empty_body> parser;
        parser.header_limit(static_cast<std::uint32_t>(config_.header_limit));
        beast::get_lowest_layer(stream).expires_after(config_.read_timeout);
        auto [error, unused] = co_await http::async_read(stream, buffer, parser, use_nothrow);
        if (error == http::error::end_of_stream || error == asio::error::eof ||
            error == asio::error::connection_reset || error == asio::error::operation_aborted)
            break;
        const auto& request = parser.get();
        WebResponse answer;
        bool done = false;  // after a refusal the connection closes: its bytes cannot be trusted
        if (error) {
            const auto reason = refusal_of_read_error(error);
            counters_.count(reason);
            if (reason == Refused::read_timeout)
                break;  // the socket is closed by the timeout: nothing to answer on
            ++counters_.requests;
            const unsigned status = reason == Refused::header_too_large ? 431 : 400;
            answer = error_response(
                status, reason == Refused::body ? "a request here has no body (every path is GET)"
                        : reason == Refused::header_too_large
                            ? "request headers over " + std::to_string(config_.header_limit) + " bytes"
                            : "not an HTTP/1.1 request: " + error.message());
            done = true;
        } else {
            ++counters_.requests;
            const bool head = request.method() == http::verb::head;
            const std::string target(request.target());
            const auto question = target.find('?');
            WebRequest asked{target.substr(0, question),
                             question == std::string::npos ? std::string() : target.substr(question + 1)};
            const auto refusal =
                access_.check(remote, request[http::field::host], request[http::field::authorization],
                              request[http::field::cookie]);
            if (request.method() != http::verb::get && !head) {
                counters_.count(Refused::method);
                answer = error_response(405, "only GET and HEAD are served here");
                answer.headers.emplace_back("Allow", "GET, HEAD");
                done = true;
            } else if (refusal == Refusal::token && asked.path != "/login") {
                counters_.count(Refused::token);
                answer = error_response(401,
                                        "beyond loopback this endpoint needs the web token: open "
                                        "/login?token=TOKEN once (plexus web --token prints it), or send "
                                        "Authorization: Bearer TOKEN");
                answer.headers.emplace_back("WWW-Authenticate", "Bearer realm=\"plexus\"");
            } else if (refusal == Refusal::host) {
                counters_.count(Refused::host);
                answer =
                    error_response(403, "ask by address (http://127.0.0.1:PORT/), or carry the web token");
            } else if (asked.path == "/api/stream" && !head) {
                co_await stream_.serve(stream, query_value(asked.query, "messages"));
                break;
            } else {
                answer = co_await routes_.answer(std::move(asked));
                if (answer.status == 404)
                    counters_.count(Refused::not_found);
                else if (answer.status == 401)
                    counters_.count(Refused::token);  // a wrong token at /login
            }
            if (stopped_)
                break;
            auto response = to_beast(answer, request.version(), request.keep_alive() && !done, head);
            beast::get_lowest_layer(stream).expires_after(config_.write_timeout);
            auto [write_error, bytes] = co_await http::async_write(stream, response, use_nothrow);
            if (write_error || done || !request.keep_alive())
                break;
            continue;
        }
        auto response = to_beast(answer, 11, false, false);
        beast::get_lowest_layer(stream).expires_after(config_.write_timeout);
        co_await http::async_write(stream, response, use_nothrow);
        break;
    }
}

}  // namespace plexus::daemon::web
