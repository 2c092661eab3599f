#pragma once
// Threading: run() is the body of Connection's receiving thread, the only thread that reads the
// socket; everything here but peer_max_frame() belongs to that thread. It takes Demux's and
// ShmRegions' mutexes (leaves) and only try-locks SendBuffer's (client/src/LOCK_ORDER.md).
//
// Reads the socket and hands what it decodes to the parts that keep it: replies and records to
// the Demux, region frames and data_shm payloads to ShmRegions, releases to count to the
// SendBuffer. It returns nothing and calls nothing back: what it learns goes into those parts.

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <mutex>
#include <optional>
#include <vector>

#include "call_book.hpp"
#include "client_rings.hpp"
#include "demux.hpp"
#include "frame_socket.hpp"
#include "plexus/proto/frame.hpp"
#include "read_demand.hpp"
#include "send_buffer.hpp"
#include "shm_regions.hpp"

namespace plexus::detail {

class Receiver {
public:
    /// Feeds `demux`, `shm` and `send` from `socket` while `demand` asks for it; all must outlive it.
    Receiver(FrameSocket& socket, ReadDemand& demand, Demux& demux, CallBook& calls, ShmRegions& shm,
             SendBuffer& send, RingsAnswerSlot& rings_answer, std::shared_ptr<ReleaseBook> releases);
    /// Closes descriptors received for frames that never came.
    ~Receiver();
    Receiver(const Receiver&) = delete;
    Receiver& operator=(const Receiver&) = delete;

    /// Reads and dispatches while anyone needs the socket read (ReadDemand), until the connection
    /// ends (the peer closed it, broke the protocol, the socket was shut down: the Demux is then
    /// broken) or the demand is stopped.
    void run();
    /// For a component's thread waiting for its own records: when no other thread reads now, it
    /// reads here itself, dispatching everything as the receiving thread would, until `ready()`,
    /// the deadline, or the connection's end; one thread woken per message instead of two. False
    /// (nothing done) when another thread is reading: wait for it instead.
    template <class Ready>
    bool read_for(Ready ready, Clock::time_point deadline) {
        if (reading_here == this)
            return false;  // a completion run by this very read: it must not read again
        std::unique_lock turn(turn_, std::try_to_lock);
        if (!turn.owns_lock())
            return false;
        reading_here = this;
        struct Done {
            ~Done() { reading_here = nullptr; }  // also when ready() throws (a broken connection)
        } done;
        while (!ready() && !demux_.broken() && Clock::now() < deadline) {
            receive(deadline);
            send_.send_releases_if_idle();
        }
        return true;
    }
    /// The largest frame body the peer takes, from its hello (the default until that came).
    std::uint64_t peer_max_frame() const { return peer_max_frame_.load(std::memory_order_relaxed); }
    /// For a TCP peer whose hello came with the handshake, before the receiving thread started.
    void set_peer_max_frame(std::uint64_t bytes) { peer_max_frame_.store(bytes, std::memory_order_relaxed); }

private:
    /// One read, waiting at most until `deadline` (not at all when it is past), and the frames it
    /// completed.
    void receive(Clock::time_point deadline);
    /// Starts receiving the frame that begins at in_begin_ (of `frame_size` bytes, not all here)
    /// straight into its message, when it is a large byte-string payload; false otherwise.
    bool start_large_payload(std::size_t frame_size);
    /// One read of the rest of that payload; delivers the message once it is whole.
    void receive_large_payload(int flags);
    /// recvmsg with the failures handled; 0 when nothing came.
    std::size_t receive_into(std::uint8_t* at, std::size_t room, int flags);
    /// Handles a frame that is neither data nor data_batch.
    void dispatch(proto::FrameType type, proto::ByteView fields);
    /// A data_shm frame: its payload, copied out of the region, to the handle's inbox.
    void receive_shm_data(proto::ByteView fields);
    /// Moves the data frames found by one receive() into the inboxes: one copy of the bytes they
    /// span and one lock for all of them, not an allocation and a lock per message.
    void deliver_received();
    void fail(const std::string& why);
    /// The daemon's `rings` answer: maps the rings and reads from them from now on.
    void take_rings(proto::ByteView fields);

    FrameSocket& socket_;
    ReadDemand& demand_;
    Demux& demux_;
    CallBook& calls_;
    ShmRegions& shm_;
    SendBuffer& send_;
    RingsAnswerSlot& rings_answer_;
    std::shared_ptr<ReleaseBook> releases_;
    /// Whose turn it is to read: the receiving thread's, or a component thread's in read_for().
    /// Everything below is used only by the thread that holds it.
    std::mutex turn_;
    static thread_local const Receiver* reading_here;  ///< the Receiver this thread reads for now
    bool just_moved_to_rings_ = false;                 ///< the rest of this socket read is descriptor markers
    std::atomic<std::uint64_t> peer_max_frame_{proto::default_max_frame};

    std::chrono::microseconds receive_timeout_{0};  ///< SO_RCVTIMEO now set; 0 = blocking forever
    proto::Bytes in_;
    std::size_t in_begin_ = 0;
    std::size_t in_end_ = 0;
    struct ReceivedData {
        std::uint64_t handle;
        std::size_t offset;  ///< of the record in in_
        std::size_t size;
    };
    std::vector<ReceivedData> received_;  ///< data frames of the current receive(), in order
    std::vector<Delivery> deliveries_;    ///< received_ as views into their block (kept for its capacity)
    struct LargePayload {
        std::uint64_t handle = 0;
        Received message;            ///< its data: the byte string, sized, being filled
        std::uint8_t* at = nullptr;  ///< the next byte to fill
        std::size_t left = 0;
    };
    std::optional<LargePayload> large_;  ///< a large payload being received straight into its message
    std::deque<int> received_fds_;       ///< descriptors received, for the shm_region frames to come
};

}  // namespace plexus::detail
