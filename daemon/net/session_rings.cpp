#include "session_rings.hpp"

#include <fcntl.h>
#include <sys/eventfd.h>
#include <sys/mman.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "plexus/proto/errno_text.hpp"

namespace plexus::daemon {

namespace {

/// Reads and so clears an eventfd's counter without ever blocking: RWF_NOWAIT is a flag of this
/// call, where O_NONBLOCK is one of the open file description, which the client shares. -1 with
/// errno EAGAIN when it is 0 (and, before Linux 5.12, EOPNOTSUPP: no such read).
ssize_t take_count(int eventfd) {
    std::uint64_t count = 0;
    iovec into{&count, sizeof count};
    return ::preadv2(eventfd, &into, 1, -1, RWF_NOWAIT);
}
}  // namespace

SessionRings::SessionRings(asio::any_io_executor executor) : data_wait_(executor), space_wait_(executor) {}

proto::Result<std::unique_ptr<SessionRings>> SessionRings::create(asio::any_io_executor executor,
                                                                  std::size_t ring_bytes) {
    std::unique_ptr<SessionRings> rings(new SessionRings(std::move(executor)));
    rings->layout_.ring_bytes = ring_bytes;
    const std::size_t size = rings->layout_.region_size();
    rings->region_fd_ = ::memfd_create("plexus-rings", MFD_CLOEXEC | MFD_ALLOW_SEALING);
    if (rings->region_fd_ < 0)
        return proto::Error{proto::errno_text("memfd_create")};
    rings->fds_[proto::ring_region] = rings->region_fd_;
    if (::ftruncate(rings->region_fd_, static_cast<off_t>(size)) != 0)
        return proto::Error{proto::errno_text("ftruncate")};
    // Sealed before the client has it: it can never shrink the region under our mapping (a
    // fault, a SIGBUS in the daemon) nor grow it.
    if (::fcntl(rings->region_fd_, F_ADD_SEALS, F_SEAL_SHRINK | F_SEAL_GROW | F_SEAL_SEAL) != 0)
        return proto::Error{proto::errno_text("sealing the rings")};
    void* mapped = ::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, rings->region_fd_, 0);
    if (mapped == MAP_FAILED)
        return proto::Error{proto::errno_text("mmap")};
    rings->region_ = static_cast<std::uint8_t*>(mapped);
    // The wake-ups (see the header): eventfds where the client signals us, pipes where we signal it.
    for (const auto which : {proto::to_daemon_data, proto::to_client_space}) {
        rings->fds_[which] = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
        if (rings->fds_[which] < 0)
            return proto::Error{proto::errno_text("eventfd")};
    }
    if (take_count(rings->fds_[proto::to_daemon_data]) >= 0 || errno != EAGAIN)
        return proto::Error{
            "this kernel cannot read an eventfd without blocking (RWF_NOWAIT: Linux 5.12 or later)"};
    for (const auto which : {proto::to_client_data, proto::to_daemon_space}) {
        int ends[2] = {-1, -1};
        if (::pipe2(ends, O_CLOEXEC | O_NONBLOCK) != 0)
            return proto::Error{proto::errno_text("pipe2")};
        rings->fds_[which] = ends[0];  // the client's, and kept open here while the session lasts
        (which == proto::to_client_data ? rings->signal_client_data_ : rings->signal_client_space_) = ends[1];
    }
    // The zeroed page is a valid state: both positions 0, nobody waiting.
    auto* to_daemon =
        reinterpret_cast<proto::RingControl*>(rings->region_ + proto::RingLayout::to_daemon_control);
    auto* to_client =
        reinterpret_cast<proto::RingControl*>(rings->region_ + proto::RingLayout::to_client_control);
    const auto& layout = rings->layout_;
    rings->from_client_ = proto::RingReader(to_daemon, rings->region_ + layout.to_daemon_data(), ring_bytes);
    rings->to_client_ = proto::RingWriter(to_client, rings->region_ + layout.to_client_data(), ring_bytes);
    // The waits get descriptors of their own: the ones in fds_ are sent to the client as they are.
    const int data = ::dup(rings->fds_[proto::to_daemon_data]);
    const int space = ::dup(rings->fds_[proto::to_client_space]);
    if (data < 0 || space < 0) {
        if (data >= 0)
            ::close(data);
        return proto::Error{proto::errno_text("dup")};
    }
    rings->data_wait_.assign(data);
    rings->space_wait_.assign(space);
    return std::move(rings);
}

SessionRings::~SessionRings() {
    close();
    if (region_)
        ::munmap(region_, layout_.region_size());
    // The write ends first: no write can then meet a pipe whose read end is gone.
    for (const int fd : {signal_client_data_, signal_client_space_}) {
        if (fd >= 0)
            ::close(fd);
    }
    for (const int fd : fds_) {
        if (fd >= 0)
            ::close(fd);
    }
}

std::vector<int> SessionRings::client_descriptors() const {
    return {fds_.begin(), fds_.end()};
}

void SessionRings::close() {
    if (closed_)
        return;
    closed_ = true;
    boost::system::error_code ignored;
    data_wait_.close(ignored);  // a wait in progress ends with operation_aborted
    space_wait_.close(ignored);
}

void SessionRings::peer_closed() {
    peer_closed_ = true;
    // A reader asleep on the ring wakes (its wait cancelled, not by a write of ours to the
    // client's eventfd, which could block) and finds the end, after whatever the client left in it.
    boost::system::error_code ignored;
    data_wait_.cancel(ignored);
}

void SessionRings::signal(int fd) {
    const std::uint64_t one = 1;
    // EAGAIN only when the client left thousands of wake-ups unread: it has plenty to wake up for.
    [[maybe_unused]] const auto ignored = ::write(fd, &one, sizeof one);
    ++wakes_sent_;
}

Task<bool> SessionRings::sleep_on(asio::posix::stream_descriptor& wait) {
    ++sleeps_;
    auto [ec] = co_await wait.async_wait(asio::posix::descriptor_base::wait_read, use_nothrow);
    if (closed_ || (ec && !(ec == asio::error::operation_aborted && peer_closed_)))
        co_return false;
    [[maybe_unused]] const auto ignored = take_count(wait.native_handle());
    co_return true;
}

Task<bool> SessionRings::spin_for_bytes() {
    const auto until = last_bytes_ + spin_;
    auto executor = co_await asio::this_coro::executor;
    while (!closed_ && !peer_closed_ && std::chrono::steady_clock::now() < until) {
        co_await asio::post(executor, asio::use_awaitable);
        const auto waiting = from_client_.available();
        if (!waiting || *waiting > 0)
            co_return true;
    }
    co_return false;
}

Task<proto::Result<std::size_t>> SessionRings::read_some(asio::mutable_buffer room) {
    for (;;) {
        if (closed_)
            co_return proto::Error{"the rings were closed"};
        bool wake = false;
        const auto n = from_client_.read_some(static_cast<std::uint8_t*>(room.data()), room.size(), wake);
        if (!n) {
            peer_lied_ = true;
            co_return proto::Error{"the client's ring says it wrote more than the ring holds"};
        }
        if (wake)
            signal(signal_client_space_);
        if (*n > 0 && spin_.count() > 0)
            last_bytes_ = std::chrono::steady_clock::now();
        if (*n > 0 || peer_closed_)
            co_return *n;  // 0 once the client closed its socket and left nothing more
        if (spin_.count() > 0 && co_await spin_for_bytes())
            continue;
        if (from_client_.prepare_to_wait())
            continue;
        const bool woken = co_await sleep_on(data_wait_);
        from_client_.done_waiting();
        if (!woken)
            co_return proto::Error{"the rings were closed"};
    }
}

Task<proto::Status> SessionRings::write(const std::vector<asio::const_buffer>& buffers) {
    pieces_.clear();
    for (const auto& buffer : buffers)
        pieces_.push_back({const_cast<void*>(buffer.data()), buffer.size()});
    std::size_t next = 0;  // the first piece not wholly written
    while (next < pieces_.size()) {
        if (closed_)
            co_return proto::Error{"the rings were closed"};
        bool wake = false;
        const auto n = to_client_.write_some(pieces_.data() + next, pieces_.size() - next, wake);
        if (!n) {
            peer_lied_ = true;
            co_return proto::Error{"the client's ring says it read more than was written"};
        }
        if (wake)
            signal(signal_client_data_);
        std::size_t written = *n;
        while (next < pieces_.size() && written >= pieces_[next].iov_len) {
            written -= pieces_[next].iov_len;
            ++next;
        }
        if (next < pieces_.size() && written > 0) {
            pieces_[next].iov_base = static_cast<std::uint8_t*>(pieces_[next].iov_base) + written;
            pieces_[next].iov_len -= written;
        }
        if (next == pieces_.size() || *n > 0)
            continue;
        if (to_client_.prepare_to_wait())
            continue;
        const bool woken = co_await sleep_on(space_wait_);
        to_client_.done_waiting();
        if (!woken)
            co_return proto::Error{"the rings were closed"};
    }
    co_return proto::Ok{};
}

}  // namespace plexus::daemon
