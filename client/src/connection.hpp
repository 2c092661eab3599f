#pragma once
// Threading: every member is safe to call from any thread. Sending holds send_mutex_; receiving is
// done by one waiting thread at a time (the "reader"), which hands frames to the others.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>

#include "frame_socket.hpp"
#include "large_payload.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/frame.hpp"
#include "shm_slots.hpp"

namespace plexus::detail {

using Clock = std::chrono::steady_clock;

/// Records delivered to one handle by one socket read: views into a block they share, so that a
/// record costs no allocation and no reference count of its own. Or one message received straight
/// into its Value (a large byte-string payload): then `whole` is set and there are no records.
struct InboxSegment {
    std::shared_ptr<const proto::Bytes> block;
    std::vector<proto::ByteView> records;
    std::optional<Received> whole;
};

/// Records waiting to be read by one Port, taken from the connection a batch at a time.
struct Inbox {
    std::deque<InboxSegment> segments;
    std::size_t next = 0;  ///< the next record of the front segment
};

/// The framed Unix-socket connection to the local daemon.
class Connection {
public:
    /// Connects to the local daemon's Unix socket.
    static std::shared_ptr<Connection> to_daemon(const std::string& socket_path);
    /// Connects over TCP to a name server (or a daemon) at HOST:PORT.
    static std::shared_ptr<Connection> to_tcp(const std::string& address);
    /// Takes a connected socket; sends our hello.
    /// `greeted`: the hellos were already exchanged (tcp_handshake); else it sends its hello now.
    Connection(int fd, std::string description, bool greeted = false);
    ~Connection();
    Connection(const Connection&) = delete;
    Connection& operator=(const Connection&) = delete;

    /// Sends a control request and waits for its reply; throws Error on timeout or a broken link.
    proto::Reply request(nlohmann::json body, std::chrono::milliseconds timeout);
    /// Queues a data frame for `handle` holding a record; sends when `flush` or the buffer is large.
    /// The payload is `payload` followed by `tail`: a large byte string is passed as its CBOR head
    /// and its bytes, and sent from where they are (a tail only comes with a large payload).
    void write(std::uint64_t handle, const std::string& source, std::uint64_t seq, proto::ByteView payload,
               proto::ByteView tail, bool flush);
    void flush();
    /// The next record delivered to `handle`, waiting until `deadline`.
    /// Moves every record delivered to `handle` so far into `into` (which must be empty), waiting
    /// up to `timeout` for the first; false if none came.
    bool read_all(std::uint64_t handle, std::chrono::milliseconds timeout, std::deque<InboxSegment>& into);
    /// Stops keeping messages for a closed handle.
    void forget(std::uint64_t handle);
    /// Tells the daemon this client maps shared-memory regions (a local daemon only); true if the
    /// daemon shares memory. Large payloads then travel through shared memory where they can.
    bool enable_shm();
    /// True once the connection failed (the daemon went away, or broke the protocol). One load.
    bool broken() const { return is_broken_.load(std::memory_order_acquire); }
    /// The largest frame body the daemon takes, from its hello (the default until that arrived;
    /// to_daemon has it once it returns: the hello comes before the reply it waits for).
    std::uint64_t peer_max_frame() const { return peer_max_frame_.load(std::memory_order_relaxed); }
    /// The socket, for a watcher that polls it for the peer's hang-up (never read from it).
    int native_handle() const { return socket_.native_handle(); }

private:
    /// Bytes the receive buffer grows by; it takes more when less than a quarter is free.
    static constexpr std::size_t read_chunk = 256 * 1024;
    /// A region the daemon gave this client to write the large payloads of one port into.
    struct WriterRegion {
        WriterRegion(std::uint64_t id_, int fd_, std::uint8_t* data_, std::size_t size_)
            : id(id_), fd(fd_), data(data_), size(size_), slots(size_) {}
        ~WriterRegion();
        std::uint64_t id;
        int fd;
        std::uint8_t* data;
        std::size_t size;
        ShmSlots slots;
        bool stalled = false;  ///< stayed full for a whole wait: do not wait again until a slot is freed
    };
    /// A region this client reads payloads of data_shm frames from, mapped read-only.
    struct ReaderRegion {
        const std::uint8_t* data = nullptr;
        std::size_t size = 0;
    };
    /// Writes a large payload into the port's region and sends where it is; false when there is
    /// no region or no room in it now (the payload then goes through the socket).
    bool write_through_shm(std::uint64_t handle, const std::string& source, std::uint64_t seq,
                           std::uint64_t time_ns, proto::ByteView payload, proto::ByteView tail);
    /// The region of `handle`, asked of the daemon the first time (sized for a few payloads like
    /// this one); null when there is none.
    WriterRegion* writer_region(std::uint64_t handle, std::size_t payload_size);
    /// A slot of `length` bytes in `region`, waiting a little for the daemon's shm_free frames
    /// when it is full (reading them itself when nobody else reads).
    std::optional<std::size_t> allocate_slot(WriterRegion& region, std::size_t length);
    /// Handles shm_region, shm_free and shm_region_gone.
    void on_shm_frame(proto::FrameType type, proto::ByteView fields);
    /// A data_shm frame: copies the payload out of the region into the handle's inbox.
    void receive_shm_data(proto::ByteView fields);
    /// Appends a shm_release frame for the data_shm frames taken since the last one.
    void append_releases_locked();
    /// Sends the releases now if the send lock is free; else whoever holds it sends them.
    void flush_releases();
    /// Reads what has arrived without waiting, if nobody else is reading.
    void receive_pending();
    /// Sends out_ now as far as the socket takes it; the rest waits for the backlog thread.
    void send_now_or_backlog_locked();
    template <typename Ready>
    bool wait_until(std::unique_lock<std::mutex>& lock, Ready ready, Clock::time_point deadline);
    /// Reads what the socket has (waiting at most until `deadline`, or not at all with
    /// MSG_DONTWAIT in `flags`) and dispatches whole frames.
    void receive(Clock::time_point deadline, int flags = 0);
    /// A send found the socket full: waits a little for room, reading meanwhile if nobody else does.
    void wait_for_room_locked();
    /// Starts receiving the frame that begins at in_begin_ (of `frame_size` bytes, not all here)
    /// straight into its message, when it is a large byte-string payload; false otherwise.
    bool start_large_payload(std::size_t frame_size);
    /// One recv of the rest of that payload; delivers the message once it is whole.
    void receive_large_payload(int flags);
    /// recv() with the errors handled; 0 when nothing came (timeout or the connection failed).
    std::size_t receive_into(std::uint8_t* at, std::size_t room, int flags);
    /// Handles a frame that is not data (replies, errors).
    void dispatch(proto::FrameType type, proto::ByteView fields);
    /// Moves the data frames found by one receive() into the inboxes: one copy of the bytes they
    /// span and one lock for all of them, not an allocation and a lock per message.
    void deliver_received();
    /// Sends all of out_, blocking until the socket takes it.
    void send_locked();
    /// Sends what the socket takes now without blocking; keeps the rest at the front of out_.
    void send_available_locked();
    /// Sends out_ and then `payload` with one gathering call per piece the socket takes: a large
    /// payload is not copied into out_ first.
    void send_with_payload_locked(proto::ByteView payload);
    /// Raises the socket's send buffer, the first time a large payload is written.
    void enlarge_send_buffer_locked();
    /// Appends the open batch (if any) to out_ as one data_batch frame.
    void close_batch_locked();
    /// The backlog thread: sends what a full socket could not take, as soon as it has room.
    void send_backlog();
    void start_backlog_thread_locked();
    void fail(const std::string& why);
    void throw_if_broken() const;

    FrameSocket socket_;
    std::string path_;

    std::mutex send_mutex_;
    proto::Bytes out_;
    // Buffered writes (flush=false) of one port in a row go into one data_batch frame: the daemons
    // then route, queue and forward them as one unit instead of message by message.
    proto::Bytes batch_;  ///< records of the open batch, each `varint length | record`
    std::uint64_t batch_handle_ = 0;
    std::uint64_t batch_count_ = 0;  ///< 0: no batch open
    bool large_send_buffer_ = false;
    // When a flushing write finds the socket full, the rest stays in out_ (the backlog) and
    // writes only append to it until it reaches the flush threshold: under saturation many
    // messages leave in one system call, while an idle link still sends each message at once.
    bool backlog_ = false;
    bool stopping_ = false;
    std::condition_variable backlog_changed_;
    std::thread backlog_thread_;  ///< started the first time a backlog forms

    mutable std::mutex state_mutex_;
    std::condition_variable changed_;
    bool reading_ = false;
    std::string broken_;
    std::atomic<bool> is_broken_{false};  ///< broken_ is set; read without the lock
    std::atomic<std::uint64_t> peer_max_frame_{proto::default_max_frame};  ///< set from the daemon's hello
    std::uint64_t next_id_ = 1;
    std::map<std::uint64_t, std::optional<proto::Reply>> replies_;
    std::map<std::uint64_t, std::deque<InboxSegment>> inbox_;
    std::set<std::uint64_t> closed_handles_;

    // Only the current reader touches these.
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
    struct LargePayload {
        std::uint64_t handle = 0;
        Received message;            ///< its data: the byte string, sized, being filled
        std::uint8_t* at = nullptr;  ///< the next byte to fill
        std::size_t left = 0;
    };
    std::optional<LargePayload> large_;  ///< a large payload being received straight into its message
    std::deque<int> received_fds_;       ///< descriptors received, for the shm_region frames to come
    std::map<std::uint64_t, ReaderRegion> reader_regions_;  ///< by region id

    // Shared memory: set up by enable_shm(), then guarded by shm_mutex_.
    bool shm_ = false;
    std::mutex shm_mutex_;
    std::map<std::uint64_t, std::unique_ptr<WriterRegion>> writer_regions_;  ///< by region id
    std::map<std::uint64_t, std::optional<std::uint64_t>> port_regions_;     ///< handle -> region id
    /// data_shm frames received and not yet released (sent back in shm_release frames).
    std::atomic<std::uint64_t> unreleased_{0};
};

}  // namespace plexus::detail
