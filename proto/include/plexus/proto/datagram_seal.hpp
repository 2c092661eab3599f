#pragma once
// Sealed datagrams (docs/SECURITY.md, "Datagrams"): with the deployment secret, the fragment of
// every udp and mcast datagram is encrypted and authenticated with AES-128-GCM under the key of
// its stream. The header stays readable (the receiver needs the stream and the fragment's place
// before it can open anything) and is authenticated as associated data.
//
// Keys are random, one per stream, never derived from the secret: the receiving daemon makes a udp
// stream's key and gives it in its answer to `attach`; the sending daemon makes an mcast stream's
// and gives it in its `attach` request. Both travel inside the TLS link the secret keys, so only
// the two daemons know them, and a datagram recorded before a daemon restarted opens under no key
// the restarted daemon holds: replay across restarts is refused. Within a stream, replay is
// refused by the stream's numbering (a message already handed on is late).
//
// The nonce is the datagram's place in its stream: the message number (8 bytes) and the fragment
// index (4 bytes). A sender never numbers two messages of one key alike, so no nonce repeats.

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "plexus/proto/bytes.hpp"
#include "plexus/proto/datagram.hpp"

namespace plexus::proto {

inline constexpr std::size_t datagram_key_size = 16;

using DatagramKey = std::array<std::uint8_t, datagram_key_size>;

/// A fresh random key from the kernel (throws std::runtime_error if it gives none).
DatagramKey random_datagram_key();
/// A key as the 32 hexadecimal digits the attach messages carry.
std::string key_text(const DatagramKey& key);
/// The key in such a text; an Error when it is not 32 hexadecimal digits.
Result<DatagramKey> parse_key_text(const std::string& text);

/// AES-128-GCM under one stream's key. Not thread-safe (one cipher context reused for every
/// datagram); cheap to keep, one per stream.
class DatagramSeal {
public:
    explicit DatagramSeal(const DatagramKey& key);
    ~DatagramSeal();
    DatagramSeal(const DatagramSeal&) = delete;
    DatagramSeal& operator=(const DatagramSeal&) = delete;

    /// Encrypts `plain` into `out` (as many bytes) and writes the tag to `tag`, binding `head`
    /// (the datagram's header) and the fragment's place (`message`, `index`).
    void seal(ByteView head, std::uint64_t message, std::uint64_t index, ByteView plain, std::uint8_t* out,
              std::uint8_t* tag);
    /// Decrypts `sealed` into `out` (as many bytes); false when the tag does not check out (the
    /// datagram was altered, forged, or sealed under another key). `out` is then garbage.
    bool open(ByteView head, std::uint64_t message, std::uint64_t index, ByteView sealed, ByteView tag,
              std::uint8_t* out);

    const DatagramKey& key() const { return key_; }

private:
    struct Cipher;
    DatagramKey key_;
    std::unique_ptr<Cipher> encrypt_;
    std::unique_ptr<Cipher> decrypt_;
};

}  // namespace plexus::proto
