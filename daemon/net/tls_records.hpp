#pragma once
// Threading: one connection's; not thread-safe (one cipher context per direction, reused).
//
// TLS 1.3's record protection (RFC 8446, section 5), done here once OpenSSL's handshake is over.
// The wire is the same TLS 1.3 OpenSSL would write (libplexus, which keeps OpenSSL's record layer,
// reads it and is read by it); what changes is the cost. OpenSSL's records went through two memory
// BIOs: a message was copied into its buffer, encrypted, copied into the BIO, copied out again to
// reach the socket, and the same three copies on the way in, with OpenSSL 3.0's cost per call on
// top. Here a batch of frames is encrypted straight from the frames into the buffer the socket
// writes, and a record is decrypted straight from the socket's buffer into the frame reader's.
// This is what kernel TLS would do in the kernel; this kernel has no `tls` module.
//
// Only what a Plexus link needs after its handshake is here: application data, alerts, key updates
// (both ways: a key is used for at most `records_per_key` records, far below AES-GCM's limit of
// 2^24.5), and session tickets (skipped: this end never resumes). Anything else is refused.

#include <openssl/types.h>

#include <boost/system/error_code.hpp>
#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include "plexus/proto/bytes.hpp"

namespace plexus::daemon {

/// The application traffic secrets of a TLS 1.3 session, as its handshake derives them. OpenSSL 3.0
/// gives them only to a key-log callback: capture_traffic_secrets() installs one on a context, and
/// a session's handshake fills the TrafficSecrets attached to it (never written anywhere else).
struct TrafficSecrets {
    proto::Bytes client;  ///< CLIENT_TRAFFIC_SECRET_0
    proto::Bytes server;  ///< SERVER_TRAFFIC_SECRET_0
    TrafficSecrets() = default;
    TrafficSecrets(const TrafficSecrets&) = delete;
    TrafficSecrets& operator=(const TrafficSecrets&) = delete;
    ~TrafficSecrets();
    /// Overwrites them (once the record layer holds its keys).
    void forget();
};

/// Makes every session of `context` fill the TrafficSecrets attach_traffic_secrets() gave it.
void capture_traffic_secrets(SSL_CTX* context);
/// `secrets` must outlive the session's handshake.
void attach_traffic_secrets(SSL* session, TrafficSecrets* secrets);

/// Bytes appended without being zeroed first (a vector's resize would write a 1 MiB batch once
/// more before it is encrypted into).
class RecordBuffer {
public:
    /// Room for `count` more bytes at the end, to be written by the caller.
    std::uint8_t* append(std::size_t count);
    std::uint8_t* data() { return bytes_.get(); }
    std::size_t size() const { return size_; }
    bool empty() const { return size_ == 0; }
    void clear() { size_ = 0; }
    /// Gives the memory back when empty and holding more than `most` (after a burst).
    void release_above(std::size_t most);

private:
    std::unique_ptr<std::uint8_t[]> bytes_;
    std::size_t size_ = 0;
    std::size_t capacity_ = 0;
};

/// The record layer of one TLS 1.3 connection after its handshake.
class TlsRecords {
public:
    /// The most plain bytes one record carries, and the most a record takes on the wire.
    static constexpr std::size_t max_plain = 16 * 1024;
    static constexpr std::size_t header_size = 5;
    static constexpr std::size_t tag_size = 16;
    static constexpr std::size_t max_record = header_size + max_plain + 256;
    /// Records sealed under one key before this end moves to the next (a KeyUpdate).
    static constexpr std::uint64_t default_records_per_key = std::uint64_t{1} << 24;

    /// The keys of `session`, whose handshake just ended and which has sent and read nothing since;
    /// nullptr when its suite is not one of TLS 1.3's AEAD suites or its secrets were not captured.
    static std::unique_ptr<TlsRecords> after_handshake(
        SSL* session, const TrafficSecrets& secrets, std::uint64_t records_per_key = default_records_per_key);
    /// The same from the suite's number (0x1301 TLS_AES_128_GCM_SHA256, 0x1302 TLS_AES_256_GCM_SHA384,
    /// 0x1303 TLS_CHACHA20_POLY1305_SHA256) and each direction's traffic secret; nullptr for another
    /// suite or secrets of the wrong size. (The fuzz target makes both ends of a link so.)
    static std::unique_ptr<TlsRecords> from_secrets(std::uint16_t suite, proto::ByteView sending,
                                                    proto::ByteView reading,
                                                    std::uint64_t records_per_key = default_records_per_key);
    ~TlsRecords();
    TlsRecords(const TlsRecords&) = delete;
    TlsRecords& operator=(const TlsRecords&) = delete;

    /// Appends `pieces`, in order, to `out` as application-data records of at most max_plain bytes
    /// each (small pieces share a record).
    void seal(std::span<const proto::ByteView> pieces, RecordBuffer& out);
    /// Appends one record of content type `type` (21 alert, 22 handshake, 23 application data)
    /// holding `content` (at most max_plain bytes): what seal() and seal_alert() do not cover.
    void seal_content(std::uint8_t type, proto::ByteView content, RecordBuffer& out);
    /// Appends a fatal alert (`description`, RFC 8446 section 6) to `out`.
    void seal_alert(std::uint8_t description, RecordBuffer& out);
    /// Whether the peer asked for a KeyUpdate that answer_key_update() has not sent yet.
    bool owes_key_update() const { return owe_key_update_; }
    /// Appends the KeyUpdate the peer asked for, if it did, and moves to the next sending key.
    void answer_key_update(RecordBuffer& out);
    /// Appends a KeyUpdate that asks the peer to update its key too, and moves to the next key.
    void request_key_update(RecordBuffer& out);

    /// The size of the record at the front of `bytes` once it is all there; 0 while its header is
    /// not; an error when the header is impossible (not application data, or too long). `alert`
    /// is then the alert to send.
    struct Framing {
        std::size_t size = 0;
        boost::system::error_code error;
        std::uint8_t alert = 0;
    };
    static Framing frame(proto::ByteView bytes);

    /// What open() found in a record.
    struct Opened {
        std::size_t plain = 0;  ///< application bytes written at `out`
        bool closed = false;    ///< the peer's close_notify
        boost::system::error_code error;
        std::uint8_t alert = 0;  ///< the alert to send for `error` (0: none, the peer sent one)
    };
    /// Opens the whole record `record` (frame() said its size) into `out`, which has room for
    /// record.size() - header_size - tag_size bytes and may be record.data() + header_size (in
    /// place). Alerts and key updates are taken here; their records give no plain bytes.
    Opened open(std::span<std::uint8_t> record, std::uint8_t* out);

private:
    struct Direction;
    /// Where sealing is in a list of pieces.
    struct Cursor {
        std::span<const proto::ByteView> pieces;
        std::size_t index = 0;
        std::size_t offset = 0;
    };
    TlsRecords(std::unique_ptr<Direction> sending, std::unique_ptr<Direction> reading,
               std::uint64_t records_per_key);
    /// Appends a record of `type` holding the next `size` bytes at `cursor`.
    void seal_record(std::uint8_t type, Cursor& cursor, std::size_t size, RecordBuffer& out);
    void seal_key_update(bool request, RecordBuffer& out);
    Opened take_handshake(proto::ByteView messages);

    std::unique_ptr<Direction> sending_;
    std::unique_ptr<Direction> reading_;
    std::uint64_t records_per_key_;
    bool owe_key_update_ = false;
};

/// The error code for an OpenSSL reason (SSL_R_...), in the category ByteStream's TLS errors use.
boost::system::error_code tls_reason(int reason);

}  // namespace plexus::daemon
