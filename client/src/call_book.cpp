#include "call_book.hpp"

#include <vector>

namespace plexus::detail {

std::uint64_t CallBook::add(Completion done, Clock::time_point deadline) {
    std::unique_lock lock(mutex_);
    if (!gone_.empty()) {
        const std::string why = gone_;
        lock.unlock();
        done(CallAnswer{proto::CallOutcome::lost, {}, why});
        return 0;
    }
    const std::uint64_t id = next_id_++;
    waiting_.emplace(id, std::move(done));
    demand_.add(deadline);
    return id;
}

bool CallBook::complete(std::uint64_t id, CallAnswer answer) {
    Completion done;
    {
        std::lock_guard lock(mutex_);
        const auto it = waiting_.find(id);
        if (it == waiting_.end())
            return false;
        done = std::move(it->second);
        waiting_.erase(it);
        demand_.remove();
    }
    done(std::move(answer));
    return true;
}

void CallBook::fail(std::uint64_t id, proto::CallOutcome outcome, std::string reason) {
    complete(id, CallAnswer{outcome, {}, std::move(reason)});
}

void CallBook::fail_all(const std::string& reason) {
    std::map<std::uint64_t, Completion> ended;
    {
        std::lock_guard lock(mutex_);
        if (gone_.empty())
            gone_ = reason;
        ended.swap(waiting_);
        incoming_.clear();
        if (!ended.empty())
            demand_.remove(static_cast<int>(ended.size()));
    }
    arrived_.notify_all();
    for (auto& [id, done] : ended)
        done(CallAnswer{proto::CallOutcome::lost, {}, reason});
}

std::size_t CallBook::waiting() const {
    std::lock_guard lock(mutex_);
    return waiting_.size();
}

void CallBook::deliver(std::uint64_t handle, IncomingCall call) {
    {
        std::lock_guard lock(mutex_);
        if (!gone_.empty() || stopped_.contains(handle))
            return;  // nobody will answer: the daemon fails it (its deadline, or the port's close)
        incoming_[handle].push_back(std::move(call));
    }
    arrived_.notify_all();
}

bool CallBook::take(std::uint64_t handle, Clock::time_point deadline, std::deque<IncomingCall>& into) {
    std::unique_lock lock(mutex_);
    const auto ready = [&] {
        if (!gone_.empty() || stopped_.contains(handle))
            return true;
        const auto it = incoming_.find(handle);
        return it != incoming_.end() && !it->second.empty();
    };
    if (!ready()) {
        demand_.add(deadline);  // the socket is read while this waits
        arrived_.wait_until(lock, deadline, ready);
        demand_.remove();
    }
    const auto it = incoming_.find(handle);
    if (it == incoming_.end() || it->second.empty())
        return false;
    into.swap(it->second);
    incoming_.erase(it);
    return true;
}

void CallBook::stop(std::uint64_t handle) {
    {
        std::lock_guard lock(mutex_);
        stopped_.insert(handle);
        incoming_.erase(handle);
    }
    arrived_.notify_all();
}

}  // namespace plexus::detail
