#include "connection.hpp"

#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <sys/un.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>

#include "blob_pool.hpp"
#include "plexus/proto/endpoint.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/hello.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/operations.hpp"
#include "plexus/proto/shm.hpp"
#include "tcp_handshake.hpp"

namespace plexus::detail {

namespace {
// Buffered writes go out once this much is waiting: large enough to batch, small enough to stream.
constexpr std::size_t flush_threshold = 64 * 1024;
// A batch frame is closed at this size: small enough that a strict queue of the default capacity
// takes several before it is full, large enough to cost the daemons little per message.
constexpr std::size_t batch_limit = 16 * 1024;
// Payloads at least this large are sent from where they are instead of being copied into out_.
constexpr std::size_t gather_threshold = 64 * 1024;
// The send buffer asked for once large payloads are written (the kernel caps it at
// net.core.wmem_max): a 1 MiB message then leaves in a few system calls instead of one per default
// 208 KiB. Streams of small messages keep the default, so that fewer of them wait in the socket.
constexpr int large_message_send_buffer = 4 * 1024 * 1024;
// How long the backlog thread waits for room before it looks at its flags again.
constexpr int backlog_poll_ms = 100;
// How long a blocked send waits for room before it looks again whether someone reads.
constexpr int room_poll_ms = 100;
// Data frames larger than this are worth writing through shared memory once a region is there.
constexpr std::size_t shm_threshold = 64 * 1024;
// How long a write waits for a slot of a full region before it takes the socket instead.
constexpr auto shm_room_wait = std::chrono::milliseconds(100);

}  // namespace

Connection::WriterRegion::~WriterRegion() {
    ::munmap(data, size);
    ::close(fd);
}

Connection::Connection(int fd, std::string description, bool greeted)
    : socket_(fd), path_(std::move(description)) {
    // socket_ is constructed first: it closes the descriptor if this constructor throws.
    in_.resize(read_chunk);
    if (greeted)
        return;
    std::lock_guard lock(send_mutex_);
    out_ = proto::encode_hello({proto::protocol_version, "client", ""});
    send_locked();
}

std::shared_ptr<Connection> Connection::to_daemon(const std::string& socket_path) {
    const int fd = FrameSocket::connect_unix(socket_path);
    auto connection = std::make_shared<Connection>(fd, socket_path);
    // A wrong program on the socket is reported now rather than at the first real request.
    proto::Reply reply = connection->request(proto::NodeRequest{}.encode(), std::chrono::milliseconds(5000));
    if (reply.code != proto::ReplyCode::ok || !proto::NodeReply::decode(reply.body))
        throw Error(ErrorCode::refused, "the program at " + socket_path + " is not plexusd");
    // PLEXUS_SHM=0 keeps every payload in the socket (for comparisons, or to rule shm out).
    const char* shm = std::getenv("PLEXUS_SHM");
    if (!shm || std::string_view(shm) != "0")
        connection->enable_shm();
    return connection;
}

std::shared_ptr<Connection> Connection::to_tcp(const std::string& address) {
    const int fd = FrameSocket::connect_tcp(address);
    std::uint64_t max_frame = 0;
    try {
        max_frame = tcp_handshake(fd, address, std::chrono::milliseconds(10000));
    } catch (...) {
        ::close(fd);
        throw;
    }
    auto connection = std::make_shared<Connection>(fd, address, true);
    if (max_frame > 0)
        connection->peer_max_frame_.store(max_frame, std::memory_order_relaxed);
    return connection;
}

Connection::~Connection() {
    try {
        flush();
    } catch (...) {
        // Nothing to report to in a destructor; the daemon notices the close.
    }
    {
        std::lock_guard lock(send_mutex_);
        stopping_ = true;
    }
    backlog_changed_.notify_all();
    if (backlog_thread_.joinable())
        backlog_thread_.join();
    for (const int fd : received_fds_)
        ::close(fd);
    for (const auto& [id, region] : reader_regions_)
        ::munmap(const_cast<std::uint8_t*>(region.data), region.size);
}

bool Connection::enable_shm() {
    const proto::Reply reply = request(proto::ShmRequest{}.encode(), std::chrono::milliseconds(5000));
    std::lock_guard lock(shm_mutex_);
    shm_ = reply.code == proto::ReplyCode::ok;
    return shm_;
}

void Connection::throw_if_broken() const {
    if (!is_broken_.load(std::memory_order_acquire))
        return;  // every write checks: no lock on the way when all is well
    std::lock_guard lock(state_mutex_);
    if (!broken_.empty())
        throw Error(ErrorCode::refused, broken_);
}

void Connection::fail(const std::string& why) {
    std::lock_guard lock(state_mutex_);
    if (broken_.empty())
        broken_ = "connection to " + path_ + " lost: " + why;
    is_broken_.store(true, std::memory_order_release);
    changed_.notify_all();
}

void Connection::send_locked() {
    send_with_payload_locked({});
}

void Connection::send_available_locked() {
    std::size_t sent = 0;
    while (sent < out_.size()) {
        const iovec piece{out_.data() + sent, out_.size() - sent};
        const SocketSent result = socket_.send_some(&piece, 1);
        if (result.full)
            break;
        if (result.failure) {
            out_.clear();
            backlog_ = false;
            fail(*result.failure);
            return;
        }
        sent += result.bytes;
    }
    out_.erase(out_.begin(), out_.begin() + static_cast<std::ptrdiff_t>(sent));
}

void Connection::send_with_payload_locked(proto::ByteView payload) {
    backlog_ = false;
    std::size_t head_sent = 0;
    std::size_t payload_sent = 0;
    while (head_sent < out_.size() || payload_sent < payload.size()) {
        iovec pieces[2];
        int count = 0;
        if (head_sent < out_.size())
            pieces[count++] = {out_.data() + head_sent, out_.size() - head_sent};
        pieces[count++] = {const_cast<std::uint8_t*>(payload.data()) + payload_sent,
                           payload.size() - payload_sent};
        const SocketSent result = socket_.send_some(pieces, static_cast<std::size_t>(count));
        if (result.full) {
            wait_for_room_locked();
            continue;
        }
        if (result.failure) {
            out_.clear();
            fail(*result.failure);
            throw_if_broken();
        }
        const auto n = result.bytes;
        const std::size_t head_part = std::min(static_cast<std::size_t>(n), out_.size() - head_sent);
        head_sent += head_part;
        payload_sent += static_cast<std::size_t>(n) - head_part;
    }
    out_.clear();
}

void Connection::wait_for_room_locked() {
    // The socket is full: the daemon is not reading it, perhaps because a strict queue that this
    // very client reads is full. The thread that would read for this client may be waiting for
    // send_mutex_, held here: then, unless someone reads meanwhile, both would wait forever. So
    // when nobody is reading, what has arrived is read here, into the inboxes, while waiting.
    bool someone_reads = false;
    {
        std::lock_guard lock(state_mutex_);
        someone_reads = reading_;
    }
    pollfd ready{socket_.native_handle(), static_cast<short>(someone_reads ? POLLOUT : POLLOUT | POLLIN), 0};
    if (::poll(&ready, 1, room_poll_ms) <= 0 || (ready.revents & POLLOUT) || !(ready.revents & POLLIN))
        return;  // room now, a timeout (look again), or an error the next send reports
    receive_pending();
}

void Connection::receive_pending() {
    {
        std::lock_guard lock(state_mutex_);
        if (reading_ || !broken_.empty())
            return;
        reading_ = true;
    }
    try {
        receive(Clock::now(), MSG_DONTWAIT);
    } catch (...) {
        std::lock_guard lock(state_mutex_);
        reading_ = false;
        changed_.notify_all();
        throw;
    }
    std::lock_guard lock(state_mutex_);
    reading_ = false;
    changed_.notify_all();
}

void Connection::write(std::uint64_t handle, const std::string& source, std::uint64_t seq,
                       proto::ByteView payload, proto::ByteView tail, bool flush) {
    if (!tail.empty() && payload.size() + tail.size() < gather_threshold) {
        // Not the large payload a tail is for: one piece, as any other.
        proto::Bytes whole(payload.begin(), payload.end());
        whole.insert(whole.end(), tail.begin(), tail.end());
        return write(handle, source, seq, whole, {}, flush);
    }
    throw_if_broken();
    const auto now = std::chrono::system_clock::now().time_since_epoch();
    const auto time_ns =
        static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(now).count());
    const std::size_t payload_size = payload.size() + tail.size();
    if (payload_size >= shm_threshold && write_through_shm(handle, source, seq, time_ns, payload, tail))
        return;
    std::lock_guard lock(send_mutex_);
    if (!flush && payload_size < gather_threshold) {
        if (batch_count_ > 0 && batch_handle_ != handle)
            close_batch_locked();
        proto::append_batch_record(batch_, source, seq, time_ns, payload);
        batch_handle_ = handle;
        if (++batch_count_ == proto::max_batch_count || batch_.size() >= batch_limit)
            close_batch_locked();
        if (out_.size() >= flush_threshold)
            send_locked();
        throw_if_broken();
        return;
    }
    close_batch_locked();      // what was buffered goes first
    append_releases_locked();  // here, not for buffered writes: those do not send out_ now
    proto::append_data_frame_prefix(out_, handle, proto::record_size(source, seq, time_ns, payload_size));
    if (payload_size >= gather_threshold) {
        enlarge_send_buffer_locked();
        proto::append_record(out_, source, seq, time_ns, {});  // the record's head; the payload ends it
        if (tail.empty()) {
            send_with_payload_locked(payload);
        } else {
            out_.insert(out_.end(), payload.begin(), payload.end());
            send_with_payload_locked(tail);
        }
        return;
    }
    proto::append_record(out_, source, seq, time_ns, payload);
    send_now_or_backlog_locked();
    throw_if_broken();
}

void Connection::send_now_or_backlog_locked() {
    if (out_.size() >= flush_threshold) {
        send_locked();
    } else if (!backlog_) {
        send_available_locked();
        if (!out_.empty()) {
            backlog_ = true;
            start_backlog_thread_locked();
            backlog_changed_.notify_one();
        }
    }
}

bool Connection::write_through_shm(std::uint64_t handle, const std::string& source, std::uint64_t seq,
                                   std::uint64_t time_ns, proto::ByteView payload, proto::ByteView tail) {
    const std::size_t length = payload.size() + tail.size();
    if (length > proto::default_max_frame)
        return false;  // the daemon takes no payload larger than a frame, however it comes
    WriterRegion* region = writer_region(handle, length);
    if (!region || length > region->size)
        return false;  // no region, or one sized for smaller payloads than this one
    const auto offset = allocate_slot(*region, length);
    if (!offset)
        return false;
    std::memcpy(region->data + *offset, payload.data(), payload.size());
    if (!tail.empty())
        std::memcpy(region->data + *offset + payload.size(), tail.data(), tail.size());
    proto::Bytes place;
    proto::append_shm_place(place, {region->id, *offset, length}, source, seq, time_ns);
    std::lock_guard lock(send_mutex_);
    close_batch_locked();  // what was buffered goes first
    append_releases_locked();
    proto::append_shm_frame_prefix(out_, handle, place.size());
    out_.insert(out_.end(), place.begin(), place.end());
    send_now_or_backlog_locked();
    throw_if_broken();
    return true;
}

Connection::WriterRegion* Connection::writer_region(std::uint64_t handle, std::size_t payload_size) {
    {
        std::lock_guard lock(shm_mutex_);
        if (!shm_)
            return nullptr;
        const auto known = port_regions_.find(handle);
        if (known != port_regions_.end()) {
            if (!known->second)
                return nullptr;
            const auto region = writer_regions_.find(*known->second);
            return region == writer_regions_.end() ? nullptr : region->second.get();
        }
    }
    // The first large write on this port asks for its region. The region's frame (and its
    // descriptor) comes before the reply, so it is here once the reply is.
    const proto::Reply reply =
        request(proto::ShmRequest{handle, payload_size}.encode(), std::chrono::milliseconds(5000));
    std::lock_guard lock(shm_mutex_);
    auto& known = port_regions_[handle];
    known.reset();
    if (reply.code != proto::ReplyCode::ok)
        return nullptr;  // shared memory used up or off: this port writes through the socket
    const auto answer = proto::ShmReply::decode(reply.body);
    if (!answer)
        return nullptr;  // not an answer this library understands: the socket will do
    const auto id = answer->region.value_or(0);
    const auto region = writer_regions_.find(id);
    if (region == writer_regions_.end())
        return nullptr;
    known = id;
    return region->second.get();
}

std::optional<std::size_t> Connection::allocate_slot(WriterRegion& region, std::size_t length) {
    std::optional<std::size_t> offset;
    bool wait = false;
    auto room = [&] {
        std::lock_guard lock(shm_mutex_);
        offset = region.slots.allocate(length);
        wait = !region.stalled;
        return offset.has_value();
    };
    // The daemon's frees for earlier slots may be waiting unread: take them first (one system call
    // that finds nothing when all is taken), so that the lowest, warmest slots are reused.
    receive_pending();
    if (room() || !wait)
        return offset;
    // Full: the readers are behind, or their releases (and the daemon's frees) are still on the
    // way, perhaps unread in this socket. Waiting for them costs less than the socket path; a
    // region that stays full past the wait is marked stalled and writes go through the socket,
    // without waiting, until a slot comes free.
    std::unique_lock lock(state_mutex_);
    if (!wait_until(lock, room, Clock::now() + shm_room_wait)) {
        std::lock_guard shm_lock(shm_mutex_);
        region.stalled = true;
    }
    return offset;
}

void Connection::enlarge_send_buffer_locked() {
    if (large_send_buffer_)
        return;
    large_send_buffer_ = true;
    socket_.set_send_buffer(large_message_send_buffer);
}

void Connection::close_batch_locked() {
    if (batch_count_ == 0)
        return;
    proto::append_batch_frame_prefix(out_, batch_handle_, batch_count_, batch_.size());
    out_.insert(out_.end(), batch_.begin(), batch_.end());
    batch_.clear();
    batch_count_ = 0;
}

void Connection::start_backlog_thread_locked() {
    if (!backlog_thread_.joinable())
        backlog_thread_ = std::thread([this] { send_backlog(); });
}

void Connection::send_backlog() {
    std::unique_lock lock(send_mutex_);
    for (;;) {
        backlog_changed_.wait(lock, [&] { return backlog_ || stopping_; });
        if (stopping_)
            return;
        lock.unlock();
        socket_.wait_writable(backlog_poll_ms);
        lock.lock();
        if (!backlog_)
            continue;
        send_available_locked();
        if (out_.empty())
            backlog_ = false;
    }
}

void Connection::flush() {
    std::lock_guard lock(send_mutex_);
    close_batch_locked();
    append_releases_locked();
    if (!out_.empty())
        send_locked();
}

proto::Reply Connection::request(nlohmann::json body, std::chrono::milliseconds timeout) {
    // The daemon would take a deeper body for a broken peer and cut the session off.
    if (proto::nesting_depth(body, proto::max_body_depth) > proto::max_body_depth) {
        throw Error(ErrorCode::usage, "the request nests arrays and maps deeper than " +
                                          std::to_string(proto::max_cbor_depth) + " levels");
    }
    std::uint64_t id = 0;
    {
        std::lock_guard state(state_mutex_);
        id = next_id_++;
        replies_[id];
    }
    try {
        std::lock_guard lock(send_mutex_);
        close_batch_locked();  // data written before the request reaches the daemon before it
        append_releases_locked();
        auto frame = proto::encode_request({id, std::move(body)});
        out_.insert(out_.end(), frame.begin(), frame.end());
        send_locked();
    } catch (...) {
        std::lock_guard state(state_mutex_);
        replies_.erase(id);  // no reply will come for a request that was not sent
        throw;
    }
    std::unique_lock lock(state_mutex_);
    const bool answered = wait_until(
        lock, [&] { return replies_[id].has_value(); }, Clock::now() + timeout);
    auto node = replies_.extract(id);
    if (answered)
        return std::move(*node.mapped());
    if (!broken_.empty())
        throw Error(ErrorCode::refused, broken_);
    throw Error(ErrorCode::timeout, path_ + " did not answer in time");
}

bool Connection::read_all(std::uint64_t handle, std::chrono::milliseconds timeout,
                          std::deque<InboxSegment>& into) {
    std::unique_lock lock(state_mutex_);
    auto ready = inbox_.find(handle);
    if (ready == inbox_.end() || ready->second.empty()) {
        // Only now is the clock read: it costs as much as the rest of a read. The entry is looked up
        // again after every wait, because forget() may erase it meanwhile.
        if (!wait_until(
                lock,
                [&] {
                    // find, not []: forget() may have erased the entry, and must stay erased.
                    const auto entry = inbox_.find(handle);
                    return entry != inbox_.end() && !entry->second.empty();
                },
                Clock::now() + timeout)) {
            if (!broken_.empty())
                throw Error(ErrorCode::refused, broken_);
            return false;
        }
        ready = inbox_.find(handle);
    }
    into.swap(ready->second);
    return true;
}

void Connection::forget(std::uint64_t handle) {
    {
        std::lock_guard lock(state_mutex_);
        inbox_.erase(handle);
        closed_handles_.insert(handle);
    }
    // The port's region goes with it (the daemon drops its side when the port closes); frees
    // that still come for it are ignored.
    std::lock_guard lock(shm_mutex_);
    const auto known = port_regions_.find(handle);
    if (known == port_regions_.end())
        return;
    if (known->second)
        writer_regions_.erase(*known->second);
    port_regions_.erase(known);
}

template <typename Ready>
bool Connection::wait_until(std::unique_lock<std::mutex>& lock, Ready ready, Clock::time_point deadline) {
    // A deadline already past (read(0ms): a poll) still looks at the socket once, without
    // blocking: otherwise a poll would only ever see what another call happened to receive.
    bool polled = false;
    while (!ready()) {
        if (!broken_.empty())
            return false;
        const bool late = Clock::now() >= deadline;
        if (late && (polled || reading_))
            return false;
        if (reading_) {
            changed_.wait_until(lock, deadline);
            continue;
        }
        reading_ = true;
        polled = late;
        lock.unlock();
        try {
            receive(deadline, late ? MSG_DONTWAIT : 0);
            flush_releases();
        } catch (...) {
            lock.lock();
            reading_ = false;
            changed_.notify_all();
            throw;
        }
        lock.lock();
        reading_ = false;
        changed_.notify_all();
    }
    return true;
}

}  // namespace plexus::detail
