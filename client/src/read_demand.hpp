#pragma once
// Threading: every member may be called from any thread. Its mutex is the innermost lock of
// libplexus: taken with Demux's, SendBuffer's or ShmRegions' held, it takes nothing itself and is
// never held while blocking (client/src/LOCK_ORDER.md).
//
// Whether anyone needs the socket read now, and until when. The receiving thread reads only while
// someone does: a port waiting for records, a requester for its reply, a writer for room on a full
// socket, a writer for a free shared-memory slot. A client that reads nothing leaves what the
// daemon sends it in the socket, so that the daemon's queues, and their policies (a strict queue
// holding its writer back, a latest queue keeping the newest), do their work: read ahead into
// the inboxes, which have no bound, messages would pile up here instead.

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>

namespace plexus::detail {

class ReadDemand {
public:
    using Clock = std::chrono::steady_clock;

    /// `count` more waits need the socket read, until `deadline` at the latest.
    void add(Clock::time_point deadline, int count = 1) {
        {
            std::lock_guard lock(mutex_);
            count_ += count;
            if (deadline > until_)
                until_ = deadline;
        }
        changed_.notify_all();
    }
    /// `count` of those waits ended (satisfied, or given up).
    void remove(int count = 1) {
        std::lock_guard lock(mutex_);
        count_ -= count;
        if (count_ <= 0) {
            count_ = 0;
            until_ = {};
        }
    }
    /// A look at the socket without waiting (a read with a timeout of zero): when the receiving
    /// thread is idle, has it make one pass now, and waits (at most `bound`) until it has. When it
    /// is busy reading for someone else, returns at once: what it reads is delivered anyway.
    void poll(Clock::duration bound) {
        std::unique_lock lock(mutex_);
        if (!idle_ || stopping_)
            return;
        const std::uint64_t start = passes_;
        ++count_;
        const auto now = Clock::now();
        if (now > until_)
            until_ = now;
        changed_.notify_all();
        changed_.wait_for(lock, bound, [&] { return passes_ != start || stopping_; });
        if (--count_ <= 0) {
            count_ = 0;
            until_ = {};
        }
    }
    /// For the receiving thread, between two reads: waits until someone needs the socket read,
    /// and answers until when; nullopt once stop() was called. A deadline already past asks for
    /// one read that does not wait, and then no more until the demand changes.
    std::optional<Clock::time_point> wait() {
        std::unique_lock lock(mutex_);
        ++passes_;
        idle_ = true;
        changed_.notify_all();  // a poll() waiting for this pass
        changed_.wait(lock, [&] {
            return stopping_ || (count_ > 0 && (until_ > Clock::now() || until_ != last_until_));
        });
        idle_ = false;
        if (stopping_)
            return std::nullopt;
        last_until_ = until_;
        return until_;
    }
    /// Ends wait(), now and for good.
    void stop() {
        {
            std::lock_guard lock(mutex_);
            stopping_ = true;
        }
        changed_.notify_all();
    }

private:
    std::mutex mutex_;
    std::condition_variable changed_;
    int count_ = 0;
    Clock::time_point until_{};       ///< the latest deadline of the waits counted
    Clock::time_point last_until_{};  ///< the deadline of the last pass: a past one is read once
    std::uint64_t passes_ = 0;        ///< reads the receiving thread finished
    bool idle_ = false;               ///< the receiving thread waits in wait()
    bool stopping_ = false;
};

}  // namespace plexus::detail
