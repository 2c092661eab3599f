#pragma once
// Threading: every member is safe to call from any thread. One thread of its own (the receiving
// thread) reads the socket, and nothing else does; it reads while someone waits for what comes
// (ReadDemand), so that a client reading nothing leaves the daemon's queues to do their work; callers send
// under SendBuffer's mutex and wait in the Demux. The parts' locks and their order: client/src/LOCK_ORDER.md.
//
// The framed connection to the local daemon (Unix socket) or to a name server (TCP): a thin
// composition of its parts, each with one job and none calling back into another:
//   FrameSocket  the socket: bytes and descriptors in, gathered bytes out
//   SendBuffer   what is sent: batches, the backlog and its thread, releases
//   ReadDemand   whether anyone needs the socket read now: the receiving thread reads only then
//   Receiver     the receiving thread's work: frames decoded and handed on
//   Demux        replies to their requesters, records to their ports, the broken state
//   CallBook     calls made, waiting for their answers; calls that reached served ports
//   ShmRegions   the shared-memory regions written into and copied out of

#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <thread>

#include "call_book.hpp"
#include "demux.hpp"
#include "frame_socket.hpp"
#include "inbox.hpp"
#include "plexus/client.hpp"
#include "plexus/proto/control.hpp"
#include "read_demand.hpp"
#include "receiver.hpp"
#include "send_buffer.hpp"
#include "shm_regions.hpp"

namespace plexus::detail {

class TlsChannel;

struct LoanSlot;

class Connection : public std::enable_shared_from_this<Connection> {
public:
    /// Connects to the local daemon's Unix socket.
    static std::shared_ptr<Connection> to_daemon(const std::string& socket_path);
    /// Connects over TCP to the name server at HOST:PORT; refused when what answers is not one (a
    /// daemon's hello, or with identities a certificate that is not a name server's).
    static std::shared_ptr<Connection> to_names(const std::string& address);
    /// Takes a connected socket and starts the receiving thread.
    /// `greeted`: the hellos were already exchanged (tcp_handshake), and the peer takes frame
    /// bodies up to `peer_max_frame` (0: it did not say); else our hello is sent now.
    /// `tls`: the TCP link's TLS (tcp_handshake.hpp), its bytes go through it.
    Connection(int fd, std::string description, bool greeted = false, std::uint64_t peer_max_frame = 0,
               std::unique_ptr<TlsChannel> tls = nullptr);
    /// Sends what is buffered, then ends the receiving thread (joined before any part goes).
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
    /// Moves every record delivered to `handle` so far into `into` (which must be empty), waiting
    /// up to `timeout` for the first; false if none came.
    bool read_all(std::uint64_t handle, std::chrono::milliseconds timeout, std::deque<InboxSegment>& into);
    /// Stops keeping messages for a closed handle.
    void forget(std::uint64_t handle);
    /// Tells the daemon this client maps shared-memory regions (a local daemon only); true if the
    /// daemon shares memory. Large payloads then travel through shared memory where they can.
    bool enable_shm();
    /// Moves this connection's frames to shared-memory rings (a local daemon only); true if the
    /// daemon made them, false when it said no (the socket then carries everything, as before).
    bool enable_rings();
    /// True once the connection failed (the daemon went away, or broke the protocol). One load.
    bool broken() const { return demux_.broken(); }
    /// The largest frame body the daemon takes, from its hello (the default until that arrived;
    /// to_daemon has it once it returns: the hello comes before the reply it waits for).
    std::uint64_t peer_max_frame() const { return receiver_.peer_max_frame(); }
    /// The socket, for a watcher that polls it for the peer's hang-up (never read from it).
    int native_handle() const { return socket_.native_handle(); }
    /// The calls this client made and those that reached its served ports (request/reply).
    CallBook& calls() { return calls_; }
    /// Sends a whole frame now (a call, an answer), after what was buffered; throws Error when the
    /// connection is broken.
    void send_frame(proto::ByteView frame);
    /// A slot of port `handle`'s shared-memory region for a blob of `size` bytes, its CBOR head
    /// written; null when there is no region or no room (the loan is then ordinary memory).
    std::shared_ptr<LoanSlot> loan(std::uint64_t handle, std::size_t size);
    /// Sends a filled loan as the record `source`/`seq` of port `handle`.
    void send_loan(std::uint64_t handle, const std::string& source, std::uint64_t seq, LoanSlot& slot);
    /// Gives back a slot lent and never sent.
    void give_back(WriterRegion& region, std::size_t offset) { shm_.give_back(region, offset); }

private:
    /// Writes a large payload into the port's region and sends where it is; false when there is
    /// no region or no room in it now (the payload then goes through the socket).
    bool write_through_shm(std::uint64_t handle, const std::string& source, std::uint64_t seq,
                           std::uint64_t time_ns, proto::ByteView payload, proto::ByteView tail);
    /// The region of `handle`, asked of the daemon the first time (sized for a few payloads like
    /// this one); null when there is none.
    std::shared_ptr<WriterRegion> writer_region(std::uint64_t handle, std::size_t payload_size);
    /// After a send: when sending failed, marks the connection broken and throws.
    void check_sent(bool sent);
    /// Ends every call still waiting with the reason the connection broke (or closed).
    void fail_calls();

    // Declared in the order they depend on each other: destroyed in reverse, each part after
    // everything that refers to it. The receiving thread is joined in the destructor's body,
    // before any of them goes.
    const std::string path_;
    FrameSocket socket_;
    ReadDemand demand_;
    Demux demux_;
    CallBook calls_;
    ShmRegions shm_;
    RingsAnswerSlot rings_answer_;
    SendBuffer send_;
    std::shared_ptr<ReleaseBook> releases_;  ///< shared with the leases of messages in shared memory
    Receiver receiver_;
    std::thread receiving_;
};

}  // namespace plexus::detail
