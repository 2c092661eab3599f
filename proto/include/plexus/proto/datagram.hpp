#pragma once
// Datagrams of the udp and mcast carriers (PROTOCOL.md, "Datagrams"): one message record, or one
// fragment of it, per datagram. Pure functions, no sockets.
//
//     datagram = raw[4] "PLXD" | u8 version | u8 flags | varint stream | varint message
//              | varint length | varint fragment_size | varint index | fragment | [raw[16] tag]
//
// A sealed datagram (flag 1, with the deployment secret: datagram_seal.hpp) carries its fragment
// encrypted, followed by the AES-GCM tag that authenticates it and the header before it.
//
// `message` counts the messages of one stream (0, 1, 2, ...): a gap is a loss. Fragment `index`
// covers bytes [index * fragment_size, min(length, (index + 1) * fragment_size)) of the record,
// so every fragment's size is known before it is copied anywhere.

#include <cstdint>

#include "plexus/proto/bytes.hpp"

namespace plexus::proto {

/// 2: sealed fragments replaced version 1's MAC of the whole datagram under one deployment key.
inline constexpr std::uint8_t datagram_version = 2;
inline constexpr std::uint8_t datagram_flag_sealed = 0x01;
/// Bytes of the tag at the end of a sealed datagram.
inline constexpr std::size_t datagram_sealed_tag_size = 16;
/// Most fragments one message may be cut into (bounds the bookkeeping of a reassembly).
inline constexpr std::uint64_t max_datagram_fragments = 1u << 16;
/// The largest header: magic, version, flags and five varints of at most 10 bytes.
inline constexpr std::size_t max_datagram_header = 4 + 1 + 1 + 5 * 10;

struct DatagramHeader {
    std::uint64_t stream = 0;
    std::uint64_t message = 0;
    std::uint64_t length = 0;  ///< the whole record's size
    std::uint64_t fragment_size = 0;
    std::uint64_t index = 0;
    bool sealed = false;  ///< the fragment is encrypted, and a tag follows it
};

struct DatagramView {
    DatagramHeader header;
    ByteView head;      ///< the header's bytes: what a seal authenticates beside the fragment
    ByteView fragment;  ///< encrypted when the datagram is sealed
    ByteView tag;       ///< empty when the datagram is not sealed
};

/// How many fragments a record of `length` bytes is cut into (at least one, for an empty record).
std::uint64_t fragment_count(std::uint64_t length, std::uint64_t fragment_size);

/// Appends a datagram header. The fragment (and the tag, if sealed) follow it.
void append_datagram_header(Bytes& out, const DatagramHeader& header);

/// Decodes a datagram; refused when it is malformed or its record would pass `max_message` bytes.
/// The reason names the field ("fragment 3 of a 2-fragment message").
Result<DatagramView> decode_datagram(ByteView datagram, std::uint64_t max_message);

}  // namespace plexus::proto
