#pragma once
// Threading: a LoanSlot belongs to the Loan that holds it (one thread at a time).
//
// A slot of a port's shared-memory region lent to the component to write one blob message into
// (Port::loan). The CBOR head of the byte string is written in front of the bytes it lends, so that
// the slot holds the whole payload when it is sent. Not sent, the slot is given back.

#include <cstddef>
#include <cstdint>
#include <memory>

namespace plexus::detail {

class Connection;
struct WriterRegion;

struct LoanSlot {
    LoanSlot(std::shared_ptr<Connection> connection_, std::uint64_t handle_,
             std::shared_ptr<WriterRegion> region_, std::size_t offset_, std::size_t length_,
             std::size_t head_size_)
        : connection(std::move(connection_)),
          handle(handle_),
          region(std::move(region_)),
          offset(offset_),
          length(length_),
          head_size(head_size_) {}
    ~LoanSlot();
    LoanSlot(const LoanSlot&) = delete;
    LoanSlot& operator=(const LoanSlot&) = delete;

    std::shared_ptr<Connection> connection;  ///< whose region it is
    std::uint64_t handle;                    ///< the port's handle on that connection
    std::shared_ptr<WriterRegion> region;
    std::size_t offset;     ///< of the payload (the CBOR head) in the region
    std::size_t length;     ///< of the whole payload: head and bytes
    std::size_t head_size;  ///< the CBOR byte-string head before the lent bytes
    bool sent = false;
};

}  // namespace plexus::detail
