#pragma once
// Threading: pure functions over messages.

#include "message.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::daemon {

/// Calls `each(const Message&)` with every record of `message` as a message of its own, sharing
/// its storage: for the places that must look at records one at a time (monitors, arbitration,
/// `latest` queues). A single record is passed as it is. The session checked the batch's records
/// when it read the frame, so walking them again cannot fail.
template <typename Each>
void for_each_record(const Message& message, Each&& each) {
    if (message.batch == 0) {
        each(message);
        return;
    }
    proto::BatchRecords records(message.record, message.batch);
    while (const auto record = records.next())
        each(Message{message.storage, *record, 0, 0});
}

/// The first `n` records of a batch (n below its count), as a batch sharing its storage.
inline Message first_records(const Message& batch, std::uint32_t n) {
    proto::BatchRecords records(batch.record, batch.batch);
    for (std::uint32_t i = 0; i < n; ++i)
        records.next();
    const auto size = static_cast<std::size_t>(records.rest().data() - batch.record.data());
    return Message{batch.storage, batch.record.first(size), 0, n};
}

/// The batch without its first `n` records (n below its count).
inline Message without_first_records(const Message& batch, std::uint32_t n) {
    proto::BatchRecords records(batch.record, batch.batch);
    for (std::uint32_t i = 0; i < n; ++i)
        records.next();
    return Message{batch.storage, records.rest(), 0, batch.batch - n};
}

}  // namespace plexus::daemon
