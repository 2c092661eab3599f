#pragma once
// Threading: every member may be called from any thread. One mutex (mutex_) guards the buffer and
// is held while sending, also while blocking for room on a full socket; the backlog thread takes
// it too. Only ReadDemand's mutex is taken while it is held, and the receiving thread only ever
// try-locks it (send_releases_if_idle), so a sender blocked on a full socket never holds up the
// reads the daemon waits for. client/src/LOCK_ORDER.md has the whole order.
//
// What this client sends: control frames, data records (small ones batched into data_batch frames,
// large ones sent from where they are), data_shm frames, and shm_release frames for the data_shm
// frames received. When a flushing write finds the socket full, the rest waits in a backlog that a
// thread of its own sends as soon as there is room, so that under saturation many messages leave in
// one system call while an idle link still sends each message at once.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "frame_socket.hpp"
#include "plexus/proto/bytes.hpp"
#include "read_demand.hpp"

namespace plexus::detail {

class ClientRings;

class SendBuffer {
public:
    /// Payloads at least this large are sent from where they are instead of being copied first.
    static constexpr std::size_t gather_threshold = 64 * 1024;

    /// Sends on `socket`; a send blocked for room registers with `demand`. Both must outlive this.
    SendBuffer(FrameSocket& socket, ReadDemand& demand) : socket_(socket), demand_(demand) {}
    /// Stops the backlog thread; what it did not send is dropped (flush() first to keep it).
    ~SendBuffer();
    SendBuffer(const SendBuffer&) = delete;
    SendBuffer& operator=(const SendBuffer&) = delete;

    // Each sending member returns false once sending failed (for good): failure() says why.

    /// Sends what was buffered, then `frame` (a whole encoded frame), blocking until the socket took it.
    bool send_frame(proto::ByteView frame);
    /// A data record for `handle`. Buffered (flush=false, a small payload) it joins a data_batch
    /// frame and leaves once enough is waiting; else it leaves now, or joins the backlog. The
    /// payload is `payload` followed by `tail`; a large one is sent from where it is.
    bool write(std::uint64_t handle, const std::string& source, std::uint64_t seq, std::uint64_t time_ns,
               proto::ByteView payload, proto::ByteView tail, bool flush);
    /// A data_shm frame for `handle`: `place` is its fields after the handle (proto::append_shm_place).
    bool write_shm(std::uint64_t handle, proto::ByteView place);
    /// Sends everything buffered, blocking until the socket took it.
    bool flush();
    /// `count` more data_shm messages were let go of (ReleaseBook): released with the next frames.
    void count_release(std::uint64_t count) { unreleased_.fetch_add(count, std::memory_order_relaxed); }
    /// For the receiving thread: sends the releases counted so far, without ever blocking: not at
    /// all when another thread holds the buffer (it sends them with its next frames), and through
    /// the backlog when the socket is full.
    void send_releases_if_idle();
    /// Ends the backlog thread (joins it); what it did not send is dropped.
    void stop();
    /// From now on frames go into the shared-memory rings, after what is buffered (sent first on
    /// the socket). False when sending had failed.
    bool send_into_rings(std::shared_ptr<ClientRings> rings);
    /// Why sending failed; nullopt while it has not.
    std::optional<std::string> failure() const;

private:
    /// Appends the open batch (if any) to out_ as one data_batch frame.
    void close_batch_locked();
    /// Appends a shm_release frame for the data_shm frames received since the last one.
    void append_releases_locked();
    /// Sends out_ now as far as the socket takes it; the rest waits for the backlog thread.
    void send_now_or_backlog_locked();
    /// Sends all of out_, blocking until the socket takes it.
    void send_locked() { send_with_payload_locked({}); }
    /// Sends out_ and then `payload` with one gathering call per piece the socket takes: a large
    /// payload is not copied into out_ first.
    void send_with_payload_locked(proto::ByteView payload);
    /// Sends what the socket takes now without blocking; keeps the rest at the front of out_.
    void send_available_locked();
    /// Remembers the first failure; shuts the socket down so that the receiving thread ends too.
    void fail_locked(const std::string& why);
    /// The backlog thread: sends what a full socket could not take, as soon as it has room.
    void send_backlog();
    void start_backlog_thread_locked();

    FrameSocket& socket_;
    ReadDemand& demand_;
    mutable std::mutex mutex_;
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
    std::optional<std::string> failure_;
    std::condition_variable backlog_changed_;
    std::thread backlog_thread_;  ///< started the first time a backlog forms
    /// data_shm messages let go of and not yet released to the daemon (sent in shm_release frames).
    std::atomic<std::uint64_t> unreleased_{0};
};

}  // namespace plexus::detail
