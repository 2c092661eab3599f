#include "send_buffer.hpp"

#include "plexus/proto/frame.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/shm.hpp"

namespace plexus::detail {

namespace {
// Buffered writes go out once this much is waiting: large enough to batch, small enough to stream.
constexpr std::size_t flush_threshold = 64 * 1024;
// A batch frame is closed at this size: small enough that a strict queue of the default capacity
// takes several before it is full, large enough to cost the daemons little per message.
constexpr std::size_t batch_limit = 16 * 1024;
// The send buffer asked for once large payloads are written (the kernel caps it at
// net.core.wmem_max): a 1 MiB message then leaves in a few system calls instead of one per default
// 208 KiB. Streams of small messages keep the default, so that fewer of them wait in the socket.
constexpr int large_message_send_buffer = 4 * 1024 * 1024;
// How long the backlog thread waits for room before it looks at its flags again.
constexpr int backlog_poll_ms = 100;
// How long a blocked send waits for room before it tries again.
constexpr int room_poll_ms = 100;
}  // namespace

SendBuffer::~SendBuffer() {
    stop();
}

void SendBuffer::stop() {
    {
        std::lock_guard lock(mutex_);
        stopping_ = true;
    }
    backlog_changed_.notify_all();
    if (backlog_thread_.joinable())
        backlog_thread_.join();
}

std::optional<std::string> SendBuffer::failure() const {
    std::lock_guard lock(mutex_);
    return failure_;
}

void SendBuffer::fail_locked(const std::string& why) {
    out_.clear();
    backlog_ = false;
    if (failure_)
        return;
    failure_ = why;
    // The receiving thread learns it from the socket (its receive ends), without a call up from
    // here; whoever sends next gets false from this buffer.
    socket_.shutdown();
}

bool SendBuffer::send_frame(proto::ByteView frame) {
    std::lock_guard lock(mutex_);
    if (failure_)
        return false;
    close_batch_locked();  // data written before a request reaches the daemon before it
    append_releases_locked();
    out_.insert(out_.end(), frame.begin(), frame.end());
    send_locked();
    return !failure_;
}

bool SendBuffer::write(std::uint64_t handle, const std::string& source, std::uint64_t seq,
                       std::uint64_t time_ns, proto::ByteView payload, proto::ByteView tail, bool flush) {
    const std::size_t payload_size = payload.size() + tail.size();
    std::lock_guard lock(mutex_);
    if (failure_)
        return false;
    if (!flush && payload_size < gather_threshold) {
        if (batch_count_ > 0 && batch_handle_ != handle)
            close_batch_locked();
        proto::append_batch_record(batch_, source, seq, time_ns, payload);
        batch_handle_ = handle;
        if (++batch_count_ == proto::max_batch_count || batch_.size() >= batch_limit)
            close_batch_locked();
        if (out_.size() >= flush_threshold)
            send_locked();
        return !failure_;
    }
    close_batch_locked();      // what was buffered goes first
    append_releases_locked();  // here, not for buffered writes: those do not send out_ now
    proto::append_data_frame_prefix(out_, handle, proto::record_size(source, seq, time_ns, payload_size));
    if (payload_size >= gather_threshold) {
        if (!large_send_buffer_) {
            large_send_buffer_ = true;
            socket_.set_send_buffer(large_message_send_buffer);
        }
        proto::append_record(out_, source, seq, time_ns, {});  // the record's head; the payload ends it
        if (tail.empty()) {
            send_with_payload_locked(payload);
        } else {
            out_.insert(out_.end(), payload.begin(), payload.end());
            send_with_payload_locked(tail);
        }
        return !failure_;
    }
    proto::append_record(out_, source, seq, time_ns, payload);
    send_now_or_backlog_locked();
    return !failure_;
}

bool SendBuffer::write_shm(std::uint64_t handle, proto::ByteView place) {
    std::lock_guard lock(mutex_);
    if (failure_)
        return false;
    close_batch_locked();  // what was buffered goes first
    append_releases_locked();
    proto::append_shm_frame_prefix(out_, handle, place.size());
    out_.insert(out_.end(), place.begin(), place.end());
    send_now_or_backlog_locked();
    return !failure_;
}

bool SendBuffer::send_into_rings(std::shared_ptr<ClientRings> rings) {
    std::lock_guard lock(mutex_);
    if (failure_)
        return false;
    close_batch_locked();
    append_releases_locked();
    if (!out_.empty())
        send_locked();
    socket_.send_into_rings(std::move(rings));
    return !failure_;
}

bool SendBuffer::flush() {
    std::lock_guard lock(mutex_);
    if (failure_)
        return false;
    close_batch_locked();
    append_releases_locked();
    if (!out_.empty())
        send_locked();
    return !failure_;
}

void SendBuffer::send_releases_if_idle() {
    if (unreleased_.load(std::memory_order_relaxed) == 0)
        return;
    std::unique_lock lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock() || failure_)
        return;  // the thread sending now appends them to its next frames
    append_releases_locked();
    // Never a blocking send here: this is the receiving thread, and a daemon holding this client
    // back would wait for it to read.
    if (backlog_)
        return;  // the backlog thread sends them with the rest
    send_available_locked();
    if (!out_.empty()) {
        backlog_ = true;
        start_backlog_thread_locked();
        backlog_changed_.notify_one();
    }
}

void SendBuffer::close_batch_locked() {
    if (batch_count_ == 0)
        return;
    proto::append_batch_frame_prefix(out_, batch_handle_, batch_count_, batch_.size());
    out_.insert(out_.end(), batch_.begin(), batch_.end());
    batch_.clear();
    batch_count_ = 0;
}

void SendBuffer::append_releases_locked() {
    if (unreleased_.load(std::memory_order_relaxed) == 0)
        return;  // every write comes here: a load, not a read-modify-write, when there is nothing
    const std::uint64_t count = unreleased_.exchange(0, std::memory_order_relaxed);
    if (count == 0)
        return;
    const auto frame = proto::make_shm_number_frame(proto::FrameType::shm_release, count);
    out_.insert(out_.end(), frame.begin(), frame.end());
}

void SendBuffer::send_now_or_backlog_locked() {
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

void SendBuffer::send_available_locked() {
    std::size_t sent = 0;
    while (sent < out_.size()) {
        const iovec piece{out_.data() + sent, out_.size() - sent};
        const SocketSent result = socket_.send_some(&piece, 1);
        if (result.full)
            break;
        if (result.failure)
            return fail_locked(*result.failure);
        sent += result.bytes;
    }
    out_.erase(out_.begin(), out_.begin() + static_cast<std::ptrdiff_t>(sent));
}

void SendBuffer::send_with_payload_locked(proto::ByteView payload) {
    backlog_ = false;
    std::size_t head_sent = 0;
    std::size_t payload_sent = 0;
    while (head_sent < out_.size() || payload_sent < payload.size()) {
        iovec pieces[2];
        std::size_t count = 0;
        if (head_sent < out_.size())
            pieces[count++] = {out_.data() + head_sent, out_.size() - head_sent};
        pieces[count++] = {const_cast<std::uint8_t*>(payload.data()) + payload_sent,
                           payload.size() - payload_sent};
        const SocketSent result = socket_.send_some(pieces, count);
        if (result.full) {
            // The socket is full: the daemon is not reading it, perhaps because it waits to send
            // to this very client (a strict queue that this client reads is full). When whoever
            // called read also read the socket, that was a deadlock to steer around: the thread
            // that would read could be this one, or wait for this lock, so a blocked send read
            // the socket itself. Now only Connection's receiving thread reads, and it never waits
            // for this lock (it only try-locks it): this send just asks it to read meanwhile (into
            // the inboxes) and waits for room, which comes once the daemon can send again.
            demand_.add(ReadDemand::Clock::now() + std::chrono::milliseconds(room_poll_ms));
            socket_.wait_writable(room_poll_ms);
            demand_.remove();
            continue;
        }
        if (result.failure)
            return fail_locked(*result.failure);
        const std::size_t head_part = std::min(result.bytes, out_.size() - head_sent);
        head_sent += head_part;
        payload_sent += result.bytes - head_part;
    }
    out_.clear();
}

void SendBuffer::start_backlog_thread_locked() {
    if (!backlog_thread_.joinable() && !stopping_)
        backlog_thread_ = std::thread([this] { send_backlog(); });
}

void SendBuffer::send_backlog() {
    std::unique_lock lock(mutex_);
    for (;;) {
        backlog_changed_.wait(lock, [&] { return backlog_ || stopping_; });
        if (stopping_)
            return;
        lock.unlock();
        socket_.wait_writable(backlog_poll_ms);
        lock.lock();
        if (!backlog_ || stopping_)
            continue;
        send_available_locked();
        if (out_.empty())
            backlog_ = false;
    }
}

}  // namespace plexus::detail
