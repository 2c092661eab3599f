#include "port.hpp"

#include <algorithm>

#include "call_routing.hpp"
#include "call_ticket.hpp"

namespace plexus::daemon {

void Port::deliver(const Message& message) {
    if (message.call && !served) [[unlikely]] {
        route_call(message);
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

void Port::route_call(const Message& message) {
    // A port that nobody serves but whose connections lead on (to servers, or to other such ports)
    // passes the call on, chosen by its own arbitration: a "service" port that callers call by
    // name, and whose events decide which server answers. Its ticket ends with the message when
    // there is nowhere to go: the caller is refused with the reason.
    CallTicket& ticket = *message.call;
    if (outgoing.empty()) {
        ++calls_refused;
        ticket.set_drop_reason("port " + name_ + " is not served: nobody answers calls there");
        return;
    }
    if (!ticket.pass_port()) {
        ++calls_refused;
        ticket.set_drop_reason("the call passed through " + std::to_string(CallTicket::max_ports) +
                               " ports without reaching a server (a loop of connections?), the last " +
                               name_);
        return;
    }
    auto chosen = choose_server(*this);
    if (const auto* why = std::get_if<std::string>(&chosen)) {
        ++calls_refused;
        ticket.set_drop_reason(*why);
        return;
    }
    Connection& connection = *std::get<Connection*>(chosen);
    send_call(connection, message);
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
