#include "port.hpp"

#include <algorithm>

#include "call_ticket.hpp"

namespace plexus::daemon {

void Port::deliver(const Message& message) {
    if (message.call && !served) [[unlikely]] {
        // Its ticket ends with the message: the caller is refused with this reason.
        ++calls_refused;
        message.call->set_drop_reason("port " + name_ + " is not served: nobody answers calls there");
        return;
    }
    received += message.count();
    if (sampler) [[unlikely]]
        sampler->offer(message);
    const bool was_empty = queue_.empty();
    queue_.push(message);
    if (was_empty && on_readable)
        on_readable();
}

void Port::mark_closed() {
    if (closed_)
        return;
    closed_ = true;
    on_readable = nullptr;
    auto callbacks = std::move(on_close_);
    on_close_.clear();
    for (auto& [owner, callback] : callbacks) {
        if (!owner.expired())
            callback();
    }
}

void Port::on_close(std::weak_ptr<void> owner, std::function<void()> callback) {
    std::erase_if(on_close_, [](const auto& entry) { return entry.first.expired(); });
    on_close_.emplace_back(std::move(owner), std::move(callback));
}

void Port::ask_priority(std::weak_ptr<void> connection, int priority) {
    std::erase_if(priorities_, [](const auto& entry) { return entry.first.expired(); });
    priorities_.emplace_back(std::move(connection), priority);
}

int Port::priority() const {
    int highest = 0;
    for (const auto& [connection, priority] : priorities_) {
        if (!connection.expired())
            highest = std::max(highest, priority);
    }
    return highest;
}

}  // namespace plexus::daemon
