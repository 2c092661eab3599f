#include "message_sampler.hpp"

#include "batch.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/message.hpp"
#include "wall_clock.hpp"

namespace plexus::daemon {

namespace {

void replace_blobs(nlohmann::json& value) {
    if (value.is_binary()) {
        value = {{"blob", value.get_binary().size()}, {"type", "blob"}};
    } else if (value.is_structured()) {
        for (auto& item : value)
            replace_blobs(item);
    }
}

}  // namespace

nlohmann::json summarise_payload(proto::ByteView payload, std::size_t largest) {
    auto value = proto::decode_cbor(payload);
    if (!value)
        return {{"undecodable", payload.size()}};
    replace_blobs(*value);
    if (value->is_structured() && value->dump().size() > largest)
        return {{"truncated", payload.size()}, {"type", value->type_name()}};
    if (value->is_string() && value->get_ref<const std::string&>().size() > largest)
        return {{"truncated", payload.size()}, {"type", "string"}};
    return std::move(*value);
}

void MessageSampler::offer(const Message& message) {
    offered_ += message.count();
    const auto now = Clock::now();
    if (now - last_taken_ < period_)
        return;
    last_taken_ = now;
    nlohmann::json sample{{"t", wall_seconds()}};
    if (message.shm) {
        // The payload is in a writer's shared memory; the record here holds only its handle.
        sample["payload"] = {{"shared_memory", true}};
        sample["size"] = nullptr;
        sample["seq"] = message.seq;
    } else {
        Message last = message;
        for_each_record(message, [&last](const Message& record) { last = record; });
        const auto record = proto::read_record(last.record);
        if (!record)
            return;
        sample["seq"] = record->seq;
        sample["source"] = std::string(record->source);
        sample["size"] = record->payload.size();
        sample["payload"] = summarise_payload(record->payload);
    }
    samples_.push_back(std::move(sample));
    while (samples_.size() > keep_)
        samples_.pop_front();
}

nlohmann::json MessageSampler::samples() const {
    nlohmann::json all = nlohmann::json::array();
    for (const auto& sample : samples_)
        all.push_back(sample);
    return all;
}

}  // namespace plexus::daemon
