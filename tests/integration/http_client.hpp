#pragma once
// A minimal HTTP/1.1 client for the web endpoint's tests: raw sockets, so a test can also send
// what no real client would (64 KiB of headers, a body on a GET, half a request) and hold many
// connections open. Blocking, with a deadline on every call.

#include <chrono>
#include <map>
#include <string>

namespace plexus::test {

struct HttpReply {
    int status = 0;                              ///< 0: no reply (closed, or nothing in time)
    std::map<std::string, std::string> headers;  ///< names lower-cased
    std::string body;
};

/// A connected TCP socket to HOST:PORT (IPv4), closed on destruction.
class HttpConnection {
public:
    /// `receive_buffer` > 0 sets SO_RCVBUF first (a client that reads slowly, or never).
    explicit HttpConnection(const std::string& address, int receive_buffer = 0);
    ~HttpConnection();
    HttpConnection(const HttpConnection&) = delete;
    HttpConnection& operator=(const HttpConnection&) = delete;
    bool connected() const { return fd_ >= 0; }
    int fd() const { return fd_; }
    /// Sends all of `bytes`; false if the peer closed.
    bool send(const std::string& bytes);
    /// Reads one response (Content-Length bodies; else until close), waiting at most `timeout`.
    HttpReply read_reply(std::chrono::milliseconds timeout = std::chrono::seconds(10));
    /// True once the peer has closed the connection (a read returns 0 or an error), polled until
    /// `timeout`.
    bool closed_by_peer(std::chrono::milliseconds timeout);
    /// Reads whatever arrives until `timeout` passes or the peer closes (the event stream).
    std::string read_for(std::chrono::milliseconds timeout);

private:
    int fd_ = -1;
    std::string pending_;
};

/// GET `path` from HOST:PORT with `extra` header lines ("Name: value\r\n"...), one connection.
HttpReply http_get(const std::string& address, const std::string& path, const std::string& extra = "");

}  // namespace plexus::test
