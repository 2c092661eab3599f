#include "reassembly.hpp"

#include <cstring>

namespace plexus::daemon {

DatagramStream::~DatagramStream() {
    for (auto& [message, unfinished] : unfinished_)
        release(unfinished);
}

void DatagramStream::release(Unfinished& unfinished) {
    if (unfinished.storage) {
        budget_->bytes -= unfinished.storage->size;
        unfinished.storage.reset();
    }
}

std::size_t DatagramStream::held_bytes() const {
    std::size_t held = 0;
    for (const auto& [message, unfinished] : unfinished_)
        held += unfinished.storage ? unfinished.storage->size : 0;
    return held;
}

void DatagramStream::skip_to(std::uint64_t message) {
    if (message <= next_)
        return;
    counters_.lost += message - next_;
    for (auto it = unfinished_.begin(); it != unfinished_.end() && it->first < message;) {
        ++counters_.incomplete;
        release(it->second);
        it = unfinished_.erase(it);
    }
    next_ = message;
}

std::optional<Message> DatagramStream::take(const proto::DatagramView& datagram, Clock::time_point now) {
    const auto& h = datagram.header;
    ++counters_.datagrams;
    if (limits_.start_anywhere && !started_) {
        if (h.message < limits_.first) {
            ++counters_.late;
            return std::nullopt;
        }
        started_ = true;
        next_ = h.message;
    }
    if (h.message < next_) {
        ++counters_.late;
        return std::nullopt;
    }
    const auto count = proto::fragment_count(h.length, h.fragment_size);
    if (count == 1) {
        if (unfinished_.contains(h.message)) {
            // Disagrees with fragments that came before it under the same number (only a broken or
            // forged sender does that). Handing it on would leave the unfinished one behind
            // `next_`, where nothing ever frees it or counts it.
            ++counters_.late;
            return std::nullopt;
        }
        // The common case, a message in one datagram: no bookkeeping, one copy.
        auto storage = std::make_shared<Chunk>(datagram.fragment.size());
        if (!datagram.fragment.empty())
            std::memcpy(storage->data(), datagram.fragment.data(), datagram.fragment.size());
        skip_to(h.message);
        next_ = h.message + 1;
        ++counters_.messages;
        return Message{storage, {storage->data(), storage->size}, h.message, 0};
    }
    auto it = unfinished_.find(h.message);
    if (it == unfinished_.end()) {
        if (unfinished_.size() >= limits_.max_unfinished) {
            // Too many at once: the oldest gives way, being the least likely to complete.
            if (h.message < unfinished_.begin()->first) {
                skip_to(h.message + 1);  // this one is the oldest (nothing before it is unfinished)
                return std::nullopt;
            }
            skip_to(unfinished_.begin()->first + 1);
        }
        if (budget_->bytes + h.length > budget_->max_bytes) {
            // Out of reassembly memory: this message is lost (and with it anything older still
            // unfinished, to keep the order); its later fragments count as late.
            skip_to(h.message + 1);
            return std::nullopt;
        }
        Unfinished fresh;
        fresh.storage = std::make_shared<Chunk>(h.length);
        budget_->bytes += h.length;
        fresh.fragment_size = h.fragment_size;
        fresh.arrived.assign(count, false);
        fresh.missing = count;
        fresh.started = now;
        it = unfinished_.emplace(h.message, std::move(fresh)).first;
    }
    auto& unfinished = it->second;
    if (unfinished.fragment_size != h.fragment_size || unfinished.storage->size != h.length) {
        ++counters_.late;  // disagrees with the fragments before it: not part of this message
        return std::nullopt;
    }
    if (unfinished.arrived[h.index]) {
        ++counters_.late;  // a duplicate
        return std::nullopt;
    }
    unfinished.arrived[h.index] = true;
    --unfinished.missing;
    std::memcpy(unfinished.storage->data() + h.index * h.fragment_size, datagram.fragment.data(),
                datagram.fragment.size());
    if (unfinished.missing != 0)
        return std::nullopt;
    std::shared_ptr<const Chunk> storage = unfinished.storage;
    budget_->bytes -= unfinished.storage->size;
    unfinished.storage.reset();
    unfinished_.erase(it);
    skip_to(h.message);
    next_ = h.message + 1;
    ++counters_.messages;
    return Message{storage, {storage->data(), storage->size}, h.message, 0};
}

void DatagramStream::expire(Clock::time_point now) {
    std::uint64_t newest_expired = 0;
    bool any = false;
    for (const auto& [message, unfinished] : unfinished_) {
        if (now - unfinished.started >= limits_.timeout) {
            newest_expired = message;
            any = true;
        }
    }
    if (any)
        skip_to(newest_expired + 1);
}

}  // namespace plexus::daemon
