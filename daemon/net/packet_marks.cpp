#include "packet_marks.hpp"

#include <netinet/in.h>

#include <cerrno>
#include <cstring>

#include "plexus/proto/carrier.hpp"

namespace plexus::daemon {

namespace {

std::string failure(const char* what, int dscp) {
    return std::string("cannot mark packets with dscp ") + std::to_string(dscp) + " (" + what +
           "): " + std::strerror(errno);
}

/// Appends one control message holding an int to `buffer` at `used`; returns the new size.
std::size_t append_int(unsigned char* buffer, std::size_t used, int level, int type, int value) {
    auto* header = reinterpret_cast<cmsghdr*>(buffer + used);
    header->cmsg_level = level;
    header->cmsg_type = type;
    header->cmsg_len = CMSG_LEN(sizeof(int));
    std::memcpy(CMSG_DATA(header), &value, sizeof value);
    return used + CMSG_SPACE(sizeof(int));
}

}  // namespace

proto::Status mark_socket(int fd, int family, int dscp) {
    const int traffic_class = dscp << 2;
    if (family == AF_INET6) {
        if (::setsockopt(fd, IPPROTO_IPV6, IPV6_TCLASS, &traffic_class, sizeof traffic_class) != 0)
            return proto::Error{failure("IPV6_TCLASS", dscp)};
    } else if (family == AF_INET) {
        if (::setsockopt(fd, IPPROTO_IP, IP_TOS, &traffic_class, sizeof traffic_class) != 0)
            return proto::Error{failure("IP_TOS", dscp)};
    } else {
        return proto::Ok{};  // a Unix socket has no packets to mark
    }
    // After IP_TOS, which has just set the priority from the old TOS bits.
    const int priority = proto::socket_priority_for_dscp(dscp);
    if (::setsockopt(fd, SOL_SOCKET, SO_PRIORITY, &priority, sizeof priority) != 0)
        return proto::Error{failure("SO_PRIORITY", dscp)};
    return proto::Ok{};
}

DatagramMarks::DatagramMarks(int family, int dscp) : family_(family), dscp_(dscp) {
    static_assert(2 * CMSG_SPACE(sizeof(int)) <= 64);
    if (family == AF_INET6)
        size_ = append_int(buffer_.data(), 0, IPPROTO_IPV6, IPV6_TCLASS, dscp << 2);
    else
        size_ = append_int(buffer_.data(), 0, IPPROTO_IP, IP_TOS, dscp << 2);
    size_ = append_int(buffer_.data(), size_, SOL_SOCKET, SO_PRIORITY, proto::socket_priority_for_dscp(dscp));
}

void DatagramMarks::drop_priority() {
    if (size_ == CMSG_SPACE(sizeof(int)))
        return;  // dropped already
    buffer_.fill(0);
    if (family_ == AF_INET6)
        size_ = append_int(buffer_.data(), 0, IPPROTO_IPV6, IPV6_TCLASS, dscp_ << 2);
    else
        size_ = append_int(buffer_.data(), 0, IPPROTO_IP, IP_TOS, dscp_ << 2);
}

}  // namespace plexus::daemon
