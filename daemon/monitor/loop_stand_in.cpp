#include "loop_stand_in.hpp"

#include <chrono>

namespace plexus::daemon::monitor {

namespace {

/// How long the stand-in waits in the loop for a handler before it looks whether the loop is
/// wanted back. give_back() waits at most this long (plus the handler running then).
constexpr auto look_back = std::chrono::microseconds(200);

}  // namespace

LoopStandIn::LoopStandIn(boost::asio::io_context& loop) : loop_(loop), thread_([this] { run(); }) {}

LoopStandIn::~LoopStandIn() {
    {
        std::lock_guard lock(mutex_);
        ending_ = true;
    }
    changed_.notify_all();
    if (thread_.get_id() == std::this_thread::get_id())
        thread_.detach();  // cannot join itself; it ends on its own right after
    else
        thread_.join();
}

void LoopStandIn::take_over() {
    if (std::this_thread::get_id() == thread_.get_id())
        return;  // it has the loop already (stages do not run inline then: stepped_in())
    {
        std::lock_guard lock(mutex_);
        running_ = true;
        back_wanted_ = false;
        wants_back_.store(false, std::memory_order_relaxed);
        stepped_in_.store(true, std::memory_order_release);
    }
    takeovers_.fetch_add(1, std::memory_order_relaxed);
    if (hand_over_.lend)
        hand_over_.lend();
    changed_.notify_all();
}

void LoopStandIn::give_back() {
    if (std::this_thread::get_id() == thread_.get_id())
        return;
    std::unique_lock lock(mutex_);
    back_wanted_ = true;
    wants_back_.store(true, std::memory_order_release);
    changed_.notify_all();
    changed_.wait(lock, [this] { return !running_; });
    stepped_in_.store(false, std::memory_order_release);
    lock.unlock();
    if (hand_over_.reclaim)
        hand_over_.reclaim();
}

void LoopStandIn::run() {
    std::unique_lock lock(mutex_);
    for (;;) {
        // Not `running_ && !back_wanted_`: the daemon's thread may want the loop back before this
        // thread has even woken, and waits for running_ to fall.
        changed_.wait(lock, [this] { return ending_ || running_; });
        if (ending_)
            return;
        lock.unlock();
        if (hand_over_.lent)
            hand_over_.lent();
        while (!wants_back_.load(std::memory_order_acquire) && !loop_.stopped())
            loop_.run_one_for(look_back);
        if (hand_over_.returned)
            hand_over_.returned();
        lock.lock();
        // A stopped loop runs nothing more: wait here for the daemon's thread to want it back.
        changed_.wait(lock, [this] { return ending_ || back_wanted_; });
        running_ = false;
        changed_.notify_all();
    }
}

}  // namespace plexus::daemon::monitor
