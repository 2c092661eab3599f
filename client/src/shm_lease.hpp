#pragma once
// Threading: a ReleaseBook may be used from any thread; its mutex is taken alone, or inside
// Demux's (a lease dropped with a closed port's inbox), and only try-locks SendBuffer's
// (client/src/LOCK_ORDER.md). A lease is a plain value owned by one thread at a time.
//
// A payload a writer on this machine put in shared memory, held where it is until this client is
// done with it. The daemon keeps the slot for this client until it is released, and releases are
// in order (`shm_release count`: the oldest `count`): a message read in place (a MessageView)
// may be let go of before an older one, so the book counts a release only once every older
// message was let go of too.

#include <sys/mman.h>

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>

#include "plexus/client.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::detail {

class SendBuffer;

/// A region mapped read-only, kept mapped while any lease of it is alive (also after the daemon
/// said it is gone).
struct ReaderMapping {
    ReaderMapping(const std::uint8_t* data_, std::size_t size_) : data(data_), size(size_) {}
    ~ReaderMapping() { ::munmap(const_cast<std::uint8_t*>(data), size); }
    ReaderMapping(const ReaderMapping&) = delete;
    ReaderMapping& operator=(const ReaderMapping&) = delete;
    const std::uint8_t* const data;
    const std::size_t size;
};

/// The releases of one connection's data_shm messages, in the order they came.
class ReleaseBook {
public:
    explicit ReleaseBook(SendBuffer& send) : send_(&send) {}
    /// A ticket for the next data_shm message received (the receiving thread).
    std::uint64_t issue();
    /// The message of `ticket` is let go of: the releases it completes are counted and, when no
    /// other thread is sending, sent now.
    void release(std::uint64_t ticket);
    /// The connection is going: releases are no longer sent (the daemon releases everything of a
    /// session that ends).
    void detach();

private:
    std::mutex mutex_;
    SendBuffer* send_;           ///< null once detached
    std::uint64_t oldest_ = 0;   ///< the ticket of released_.front()
    std::deque<bool> released_;  ///< per ticket from oldest_: let go of yet
};

/// One data_shm message held in its region for this client.
struct ShmLease {
    ShmLease(std::shared_ptr<const ReaderMapping> mapping_, proto::ByteView payload_, Envelope envelope_,
             std::shared_ptr<ReleaseBook> book_, std::uint64_t ticket_)
        : mapping(std::move(mapping_)),
          payload(payload_),
          envelope(std::move(envelope_)),
          book(std::move(book_)),
          ticket(ticket_) {}
    ~ShmLease() { book->release(ticket); }
    ShmLease(const ShmLease&) = delete;
    ShmLease& operator=(const ShmLease&) = delete;

    std::shared_ptr<const ReaderMapping> mapping;
    proto::ByteView payload;  ///< the CBOR payload, in the mapping (read-only)
    Envelope envelope;
    std::shared_ptr<ReleaseBook> book;
    std::uint64_t ticket;
};

}  // namespace plexus::detail
