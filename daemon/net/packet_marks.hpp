#pragma once
// Threading: pure functions on a socket descriptor; any thread.
//
// The marks a connection's `qos.dscp.N` puts on its packets: the DSCP in the IP header (IP_TOS for
// IPv4, IPV6_TCLASS for IPv6: DSCP << 2, ECN bits left 0) and the matching socket priority
// (SO_PRIORITY), which is what Linux queueing disciplines such as pfifo_fast sort by. Setting
// IP_TOS makes Linux set the priority too, from the old TOS bits, so the priority is set after it
// (proto::socket_priority_for_dscp says which).

#include <sys/socket.h>

#include <array>
#include <cstddef>
#include <string>

#include "plexus/proto/bytes.hpp"

namespace plexus::daemon {

/// Marks every packet sent on the TCP/UDP socket `fd` (of address family `family`) with `dscp`.
proto::Status mark_socket(int fd, int family, int dscp);

/// Ancillary data that marks one datagram (sendmsg/sendmmsg) with a DSCP and its priority, for a
/// socket shared by connections of different marks. Filled once per connection.
class DatagramMarks {
public:
    /// `family` is the sending socket's (AF_INET or AF_INET6).
    DatagramMarks(int family, int dscp);
    void* data() { return buffer_.data(); }
    std::size_t size() const { return size_; }
    /// The same marks without the priority, for a kernel that refuses SO_PRIORITY as ancillary
    /// data (before Linux 6.13): the DSCP still goes out, the local queueing does not see it.
    void drop_priority();

private:
    alignas(cmsghdr) std::array<unsigned char, 64> buffer_{};
    std::size_t size_ = 0;
    int family_;
    int dscp_;
};

}  // namespace plexus::daemon
