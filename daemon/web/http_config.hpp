#pragma once
// Threading: values.
//
// The web endpoint's settings (docs/WEB.md): where it listens, and the bounds that keep a hostile
// or broken browser from costing the daemon more than a little memory and a few descriptors.

#include <chrono>
#include <cstddef>
#include <optional>

#include "plexus/proto/endpoint.hpp"

namespace plexus::daemon::web {

struct HttpConfig {
    std::optional<proto::Endpoint> listen;  ///< --http HOST:PORT (config "http"); none: off
    /// Connections served at once; one more is answered 503 and closed. A page holds two or three.
    std::size_t max_connections = 256;
    /// Request line and headers together (a browser sends under 2 KiB): beyond it, 431.
    std::size_t header_limit = 8 * 1024;
    /// A request must arrive whole within this (a slow-loris client holds a slot no longer), and
    /// an idle kept-alive connection is closed after it.
    std::chrono::milliseconds read_timeout{10000};
    /// A response, or one event of the stream, must be taken by the client within this.
    std::chrono::milliseconds write_timeout{10000};
    /// Events waiting for a stream client that does not read: beyond it the client is dropped.
    std::size_t stream_backlog_bytes = 1024 * 1024;
    /// How often the stream sends the arbitration of every arbitrated port (20 Hz: DESIGN's
    /// stimulation decays within tc, often 0.5 s; a plot needs several points per decay).
    std::chrono::milliseconds arbitration_period{50};
    /// How often it sends the whole system (graph and counters).
    std::chrono::milliseconds system_period{1000};
};

}  // namespace plexus::daemon::web
