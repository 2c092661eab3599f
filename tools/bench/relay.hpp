#pragma once
// The floor's relay: the least a broker hop must do. It joins two stream sockets ("sides") and
// forwards whole length-prefixed frames (floor_frame.hpp) from each to the other, on one thread with
// epoll, like plexusd's single io_context thread: read what is there, send every whole frame in one
// send, keep the partial tail, and stop reading a side while the other cannot take more.
//
// Topologies (the same processes and socket hops as Plexus):
//   one hop:  client A --unix-- relay --unix-- client B            (the relay pairs its first two clients)
//   two hops: client A --unix-- relay a --tcp-- relay b --unix-- client B
//   two hops over udp: the same with a connected UDP socket between the relays, one datagram per
//                      frame (latency only: frames up to 64 KiB, no loss recovery, as a udp floor)

#include <string>

namespace plexus::bench {

struct RelayOptions {
    std::string socket;        ///< Unix socket to accept clients on
    std::string ready_file;    ///< written (JSON: pid, link) once the sockets are bound
    bool link_listen = false;  ///< two hops, near side: accept the other relay over TCP on 127.0.0.1:0
    std::string link_connect;  ///< two hops, far side: connect to the other relay at 127.0.0.1:PORT
    /// The address the near side's link listens on (`plexus-bench hosts`: its host's eth0).
    std::string link_address = "127.0.0.1";
    bool udp_link = false;  ///< two hops: the relays exchange frames as datagrams, not over TCP
};

/// Runs a relay until one side closes; the exit status for main.
int run_relay(const RelayOptions& options);

}  // namespace plexus::bench
