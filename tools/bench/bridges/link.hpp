#pragma once
// One end of a path the bridges bench measures: it publishes payloads on one topic and receives
// them on another, over DDS (dds_link) or MQTT (mqtt_link). The ping-pong and the stream (ends.cpp)
// are written once against this.
#include <chrono>
#include <cstdint>
#include <optional>
#include <span>
#include <vector>

namespace plexus::bench::bridges {

class Link {
public:
    virtual ~Link() = default;
    /// Publishes `payload` (the first 8 bytes are the message's number).
    virtual void publish(std::span<const std::uint8_t> payload) = 0;
    /// The next payload received, within `timeout`.
    virtual std::optional<std::vector<std::uint8_t>> receive(std::chrono::milliseconds timeout) = 0;
    /// True once the other side is known to listen and publish (DDS: matched; MQTT: subscribed).
    virtual bool ready() = 0;
};

}  // namespace plexus::bench::bridges
