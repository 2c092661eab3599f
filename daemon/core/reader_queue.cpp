#include "reader_queue.hpp"

#include "batch.hpp"

namespace plexus::daemon {

std::optional<QueuePolicy> parse_queue_policy(std::string_view text) {
    if (text == "strict")
        return QueuePolicy::strict;
    if (text == "latest")
        return QueuePolicy::latest;
    return std::nullopt;
}

std::string_view queue_policy_name(QueuePolicy policy) {
    return policy == QueuePolicy::strict ? "strict" : "latest";
}

void ReaderQueue::push(const Message& message) {
    if (policy_ == QueuePolicy::latest && message.batch != 0) {
        // A latest queue drops single messages, so it keeps them one by one.
        for_each_record(message, [this](const Message& single) { push(single); });
        return;
    }
    pushed_ += message.count();
    messages_ += message.count();
    items_.push_back(message);
    bytes_ += message.record.size();
    if (policy_ == QueuePolicy::latest) {
        // Always keep the newest message, even one larger than the byte bound on its own.
        while (items_.size() > 1 && (items_.size() > capacity_ || bytes_ > max_bytes_)) {
            bytes_ -= items_.front().record.size();
            items_.pop_front();
            --messages_;
            ++dropped_;
        }
    }
}

Message ReaderQueue::pop() {
    Message front = std::move(items_.front());
    items_.pop_front();
    bytes_ -= front.record.size();
    messages_ -= front.count();
    return front;
}

}  // namespace plexus::daemon
