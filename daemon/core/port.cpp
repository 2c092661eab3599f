#include "port.hpp"

namespace plexus::daemon {

void Port::deliver(const Message& message) {
    received += message.count();
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
    auto callbacks = std::move(on_close);
    on_close.clear();
    for (auto& callback : callbacks)
        callback();
}

}  // namespace plexus::daemon
