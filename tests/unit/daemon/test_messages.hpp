#pragma once
// Messages and batches for the daemon's unit tests, each in a chunk of its own.

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/batch.hpp"
#include "core/message.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::daemon::test {

/// A message holding `bytes`: one record (batch = 0) or the records of a batch of that many.
inline Message message_holding(const proto::Bytes& bytes, std::uint32_t batch = 0) {
    auto chunk = std::make_shared<Chunk>(bytes.size());
    if (!bytes.empty())
        std::memcpy(chunk->data(), bytes.data(), bytes.size());
    const proto::ByteView view(chunk->data(), bytes.size());
    return Message{std::move(chunk), view, 0, batch};
}

/// A batch of `n` records from `source` with seq 1..n; `payload(seq)` gives each payload.
template <typename Payload>
Message batch_of(std::uint32_t n, const std::string& source, Payload payload) {
    proto::Bytes records;
    for (std::uint32_t seq = 1; seq <= n; ++seq)
        proto::append_batch_record(records, source, seq, 0, payload(seq));
    return message_holding(records, n);
}

/// The seq of every record of a message, in order.
inline std::vector<std::uint64_t> seqs_of(const Message& message) {
    std::vector<std::uint64_t> seqs;
    for_each_record(message,
                    [&](const Message& single) { seqs.push_back(proto::decode_record(single.record)->seq); });
    return seqs;
}

/// One record from /a with `seq`, a fixed time and `payload` as CBOR: what a monitor sees.
inline Message json_message(const nlohmann::json& payload, std::uint64_t seq = 7) {
    proto::Bytes bytes;
    proto::append_record(bytes, "/a", seq, 1'500'000'000'000'000'000ull, nlohmann::json::to_cbor(payload));
    Message message = message_holding(bytes);
    message.seq = seq;
    return message;
}

/// The payload of a one-record message, decoded.
inline nlohmann::json payload_of(const Message& message) {
    auto record = proto::decode_record(message.record);
    if (!record.ok())
        return nlohmann::json();  // the caller's comparison fails and shows it
    return nlohmann::json::from_cbor(record->payload.begin(), record->payload.end());
}

}  // namespace plexus::daemon::test
