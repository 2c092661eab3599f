#include "reader_queue.hpp"

namespace plexus::daemon {

std::optional<QueuePolicy> parse_queue_policy(std::string_view text) {
    if (text == "strict") return QueuePolicy::strict;
    if (text == "latest") return QueuePolicy::latest;
    return std::nullopt;
}

std::string_view queue_policy_name(QueuePolicy policy) {
    return policy == QueuePolicy::strict ? "strict" : "latest";
}

void ReaderQueue::push(const Message& message) {
    ++pushed_;
    if (policy_ == QueuePolicy::latest && items_.size() >= capacity_) {
        items_.pop_front();
        ++dropped_;
    }
    items_.push_back(message);
}

Message ReaderQueue::pop() {
    Message front = std::move(items_.front());
    items_.pop_front();
    return front;
}

}  // namespace plexus::daemon
