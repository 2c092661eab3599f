#pragma once
// The two ends of a bridges-bench path, each a process of its own inside the bench's namespace:
// the pinger times round trips and a windowed stream and prints its figures as one JSON line; the
// echo sends back what it receives (the "same shape" of the path without Plexus).
#include <cstddef>
#include <string>

namespace plexus::bench::bridges {

struct EndOptions {
    std::string link = "dds";  ///< dds or mqtt
    std::string out;           ///< the topic it publishes on
    std::string in;            ///< the topic it receives from
    std::string broker = "127.0.0.1:1883";
    int qos = 1;
    std::size_t size = 64;
    std::size_t count = 2000;  ///< timed round trips
    std::size_t stream = 0;    ///< messages of the windowed stream (0: none)
    /// At most this many in flight in the stream: fewer than the keep-last 10 of ROS 2's default QoS
    /// on the way, which a stream that outran a reader would lose messages to.
    std::size_t window = 8;
};

/// Prints {"rtt_us": [sorted...]-summary, "stream_msgs_per_s", "lost"}; returns the exit status.
int run_ping(const EndOptions& options);
/// Runs until SIGTERM.
int run_echo(const EndOptions& options);

}  // namespace plexus::bench::bridges
