#pragma once
// An input port that a loop can empty without waiting. Port::read(0 ms) does not do it: a read
// with a deadline already past returns before it looks at the socket, so it only ever hands out
// what another read took in. Here a Subscription (a thread of its own, waiting up to 100 ms at a
// time) reads the port and puts each message in a queue, and the loop takes the whole queue per tick.
//
// Threading: the subscription thread pushes, one other thread takes; one mutex guards the queue.
#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <vector>

#include "plexus/client.hpp"

namespace plexus::sim {

class InputQueue {
public:
    /// Opens `name` on `client` and starts reading it. At most `capacity` messages wait here (the
    /// oldest are dropped beyond, and counted): the port's own queue policy decides the rest.
    InputQueue(Client& client, const std::string& name, PortOptions options, std::size_t capacity = 1000)
        : port_(client.open(name, options)), capacity_(capacity) {
        subscription_ = std::make_unique<Subscription>(port_, [this](const Received& message) {
            std::lock_guard lock(mutex_);
            if (waiting_.size() >= capacity_) {
                waiting_.pop_front();
                ++dropped_;
            }
            waiting_.push_back(message.data);
        });
    }

    ~InputQueue() {
        subscription_.reset();  // stops the thread before the port and the queue go
    }

    InputQueue(const InputQueue&) = delete;
    InputQueue& operator=(const InputQueue&) = delete;

    /// Everything that arrived since the last call, oldest first.
    std::vector<Value> take() {
        std::lock_guard lock(mutex_);
        std::vector<Value> taken(std::make_move_iterator(waiting_.begin()),
                                 std::make_move_iterator(waiting_.end()));
        waiting_.clear();
        return taken;
    }

    /// Messages dropped here because the loop did not take them in time.
    std::uint64_t dropped() const {
        std::lock_guard lock(mutex_);
        return dropped_;
    }

    const std::string& name() const { return port_.name(); }

private:
    Port port_;
    std::size_t capacity_;
    mutable std::mutex mutex_;
    std::deque<Value> waiting_;
    std::uint64_t dropped_ = 0;
    std::unique_ptr<Subscription> subscription_;
};

}  // namespace plexus::sim
