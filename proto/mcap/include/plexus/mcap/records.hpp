#pragma once
// What an MCAP file describes, as the writer takes it and the reader returns it: schemas,
// channels, metadata and statistics. The byte layout of each record is in src/format.hpp.

#include <cstdint>
#include <map>
#include <string>

#include "plexus/proto/bytes.hpp"

namespace plexus::mcap {

using StringMap = std::map<std::string, std::string>;

/// How the messages of channels that name it are encoded (MCAP Schema record).
struct Schema {
    std::uint16_t id = 0;  ///< never 0: 0 means "no schema" in a channel
    std::string name;
    std::string encoding;  ///< e.g. "jsonschema"; "" when there is none
    proto::Bytes data;
    bool operator==(const Schema&) const = default;
};

/// One recorded stream of messages (MCAP Channel record): for Plexus, one port.
struct Channel {
    std::uint16_t id = 0;
    std::uint16_t schema_id = 0;  ///< 0: no schema
    std::string topic;
    std::string message_encoding;
    StringMap metadata;
    bool operator==(const Channel&) const = default;
};

/// A named set of key/value strings stored in the file (MCAP Metadata record).
struct Metadata {
    std::string name;
    StringMap values;
    bool operator==(const Metadata&) const = default;
};

/// Counts and time range of the file (MCAP Statistics record).
struct Statistics {
    std::uint64_t message_count = 0;
    std::uint16_t schema_count = 0;
    std::uint32_t channel_count = 0;
    std::uint32_t attachment_count = 0;
    std::uint32_t metadata_count = 0;
    std::uint32_t chunk_count = 0;
    std::uint64_t message_start_time = 0;  ///< earliest log_time; 0 when there are no messages
    std::uint64_t message_end_time = 0;    ///< latest log_time; 0 when there are no messages
    std::map<std::uint16_t, std::uint64_t> channel_message_counts;
    bool operator==(const Statistics&) const = default;
};

}  // namespace plexus::mcap
