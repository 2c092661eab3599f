#pragma once
// Threading: owned by the daemon's one thread; no locking.
//
// A port's last messages, sampled for a person watching (docs/WEB.md, `/api/messages`): at most
// one message per period is decoded and kept, the newest `keep`. A port has a sampler only while
// someone asks; without one, delivering costs one null check.

#include <chrono>
#include <cstddef>
#include <deque>

#include <nlohmann/json.hpp>

#include "message.hpp"

namespace plexus::daemon {

class MessageSampler {
public:
    using Clock = std::chrono::steady_clock;
    static constexpr std::size_t default_keep = 20;
    static constexpr std::chrono::milliseconds default_period{100};
    /// A payload whose JSON is longer than this is summarised by its size and type.
    static constexpr std::size_t largest_shown = 4096;

    explicit MessageSampler(std::size_t keep = default_keep, Clock::duration period = default_period)
        : keep_(keep), period_(period) {}

    /// Keeps `message` (its last record, for a batch) unless one was kept less than a period ago.
    void offer(const Message& message);
    /// The kept messages, oldest first: `[{"t", "seq", "size", "payload"}]`.
    nlohmann::json samples() const;
    /// How many were offered since the sampler was made (the page shows the rate).
    std::uint64_t offered() const { return offered_; }

    /// When someone last asked: the web endpoint drops samplers nobody asked for a while.
    Clock::time_point last_asked = Clock::now();

private:
    std::size_t keep_;
    Clock::duration period_;
    Clock::time_point last_taken_{};
    std::uint64_t offered_ = 0;
    std::deque<nlohmann::json> samples_;
};

/// The payload (CBOR bytes) as JSON for a person: blobs anywhere inside replaced by
/// `{"blob": SIZE, "type": "blob"}`, the whole by `{"truncated": SIZE, "type": T}` when its JSON
/// is longer than `largest`, `{"undecodable": SIZE}` when it is not CBOR.
nlohmann::json summarise_payload(proto::ByteView payload,
                                 std::size_t largest = MessageSampler::largest_shown);

}  // namespace plexus::daemon
