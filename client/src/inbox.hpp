#pragma once
// Threading: plain values. A segment is built by the receiving thread, kept under Demux's mutex,
// and then belongs to the one Port that took it.

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <vector>

#include "plexus/client.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::detail {

/// Records delivered to one handle by one socket read: views into a block they share, so that a
/// record costs no allocation and no reference count of its own. Or one message received straight
/// into its Value (a large byte-string payload): then `whole` is set and there are no records.
struct ShmLease;

/// Or one message still in a shared-memory region (`lease`): copied out when it is read, or read
/// where it is (Port::read_view).
struct InboxSegment {
    std::shared_ptr<const proto::Bytes> block;
    std::vector<proto::ByteView> records;
    std::optional<Received> whole;
    std::shared_ptr<ShmLease> lease;
};

/// Records waiting to be read by one Port, taken from the connection a batch at a time.
struct Inbox {
    std::deque<InboxSegment> segments;
    std::size_t next = 0;  ///< the next record of the front segment
};

}  // namespace plexus::detail
