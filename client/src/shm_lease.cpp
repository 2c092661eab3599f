#include "shm_lease.hpp"

#include "send_buffer.hpp"

namespace plexus::detail {

std::uint64_t ReleaseBook::issue() {
    std::lock_guard lock(mutex_);
    released_.push_back(false);
    return oldest_ + released_.size() - 1;
}

void ReleaseBook::release(std::uint64_t ticket) {
    std::lock_guard lock(mutex_);
    if (ticket < oldest_ || ticket - oldest_ >= released_.size())
        return;  // cannot happen: each lease releases its own ticket once
    released_[ticket - oldest_] = true;
    std::uint64_t done = 0;
    while (!released_.empty() && released_.front()) {
        released_.pop_front();
        ++oldest_;
        ++done;
    }
    if (done == 0 || !send_)
        return;
    send_->count_release(done);
    // Sent now when nobody else sends (a try-lock: never waits for a sender); else with the next frames.
    send_->send_releases_if_idle();
}

void ReleaseBook::detach() {
    std::lock_guard lock(mutex_);
    send_ = nullptr;
}

}  // namespace plexus::detail
