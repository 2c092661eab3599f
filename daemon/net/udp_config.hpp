#pragma once
// Threading: values.

#include <chrono>
#include <cstddef>

namespace plexus::daemon {

struct UdpConfig {
    /// Record bytes per datagram. 1,400 keeps a datagram (with its IP and UDP headers and the
    /// Plexus header) inside an Ethernet or Wi-Fi MTU of 1,500: the network never fragments it,
    /// so one lost frame loses one fragment, not a whole 64 KiB datagram.
    std::size_t fragment_bytes = 1400;
    /// Largest message (record) the carrier takes; larger ones are dropped at the sender, counted
    /// and logged, and refused at the receiver.
    std::size_t max_message = 16u * 1024u * 1024u;
    /// Bytes all unfinished messages may hold together at the receiver.
    std::size_t reassembly_bytes = 64u * 1024u * 1024u;
    /// An unfinished message older than this is counted lost.
    std::chrono::milliseconds reassembly_timeout{1000};
    /// Hops a multicast datagram may travel: 1 keeps the mcast carrier on the local network.
    int mcast_ttl = 1;
};

}  // namespace plexus::daemon
