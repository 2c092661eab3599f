#include "tls_records.hpp"

#include <openssl/crypto.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/ssl.h>

#include <algorithm>
#include <array>
#include <boost/asio/ssl/error.hpp>
#include <cstring>
#include <stdexcept>
#include <string_view>

#include "plexus/proto/hex.hpp"

namespace plexus::daemon {

namespace {

// RFC 8446's content types and the handshake messages a connection may see after its handshake.
constexpr std::uint8_t alert_type = 21;
constexpr std::uint8_t handshake_type = 22;
constexpr std::uint8_t application_data_type = 23;
constexpr std::uint8_t new_session_ticket = 4;
constexpr std::uint8_t key_update = 24;
constexpr std::uint8_t close_notify = 0;
constexpr std::uint8_t user_canceled = 90;
constexpr std::size_t nonce_size = 12;

int secrets_index() {
    static const int index = ::SSL_get_ex_new_index(0, nullptr, nullptr, nullptr, nullptr);
    return index;
}

void cleanse(proto::Bytes& bytes) {
    if (!bytes.empty())
        ::OPENSSL_cleanse(bytes.data(), bytes.size());
    bytes.clear();
}

/// A line of OpenSSL's key log ("CLIENT_TRAFFIC_SECRET_0 <client random> <secret>", in hex): the
/// application traffic secrets go into the session's TrafficSecrets, the rest is not kept.
void take_key_log_line(const SSL* session, const char* line) {
    auto* secrets = static_cast<TrafficSecrets*>(::SSL_get_ex_data(session, secrets_index()));
    if (!secrets)
        return;
    const std::string_view text(line);
    proto::Bytes* into = nullptr;
    if (text.starts_with("CLIENT_TRAFFIC_SECRET_0 "))
        into = &secrets->client;
    else if (text.starts_with("SERVER_TRAFFIC_SECRET_0 "))
        into = &secrets->server;
    if (!into)
        return;
    const std::string_view digits = text.substr(text.rfind(' ') + 1);
    cleanse(*into);
    for (std::size_t i = 0; i + 1 < digits.size(); i += 2) {
        const int high = proto::hex_digit_value(digits[i]);
        const int low = proto::hex_digit_value(digits[i + 1]);
        if (high < 0 || low < 0) {
            cleanse(*into);  // not what OpenSSL writes: after_handshake() refuses the session
            return;
        }
        into->push_back(static_cast<std::uint8_t>(high << 4 | low));
    }
}

/// HKDF-Expand-Label (RFC 8446, section 7.1) with an empty context, for lengths up to the hash's:
/// one HMAC of the label.
proto::Bytes expand_label(const EVP_MD* digest, proto::ByteView secret, std::string_view label,
                          std::size_t length) {
    proto::Bytes info;
    info.push_back(static_cast<std::uint8_t>(length >> 8));
    info.push_back(static_cast<std::uint8_t>(length));
    const std::string full = std::string("tls13 ") + std::string(label);
    info.push_back(static_cast<std::uint8_t>(full.size()));
    info.insert(info.end(), full.begin(), full.end());
    info.push_back(0);  // the context: empty
    info.push_back(1);  // HKDF-Expand's first block
    std::array<std::uint8_t, EVP_MAX_MD_SIZE> block{};
    unsigned int made = 0;
    if (length > static_cast<std::size_t>(::EVP_MD_get_size(digest)) ||
        ::HMAC(digest, secret.data(), static_cast<int>(secret.size()), info.data(), info.size(), block.data(),
               &made) == nullptr)
        throw std::runtime_error("OpenSSL could not derive a TLS 1.3 traffic key");
    proto::Bytes out(block.begin(), block.begin() + static_cast<std::ptrdiff_t>(length));
    ::OPENSSL_cleanse(block.data(), block.size());
    return out;
}

}  // namespace

boost::system::error_code tls_reason(int reason) {
    return {static_cast<int>(ERR_PACK(ERR_LIB_SSL, 0, reason)), boost::asio::error::get_ssl_category()};
}

TrafficSecrets::~TrafficSecrets() {
    forget();
}

void TrafficSecrets::forget() {
    cleanse(client);
    cleanse(server);
}

void capture_traffic_secrets(SSL_CTX* context) {
    ::SSL_CTX_set_keylog_callback(context, take_key_log_line);
}

void attach_traffic_secrets(SSL* session, TrafficSecrets* secrets) {
    ::SSL_set_ex_data(session, secrets_index(), secrets);
}

std::uint8_t* RecordBuffer::append(std::size_t count) {
    if (size_ + count > capacity_) {
        const std::size_t capacity = std::max(size_ + count, 2 * capacity_);
        auto bigger = std::make_unique_for_overwrite<std::uint8_t[]>(capacity);
        if (size_ > 0)
            std::memcpy(bigger.get(), bytes_.get(), size_);
        bytes_ = std::move(bigger);
        capacity_ = capacity;
    }
    std::uint8_t* at = bytes_.get() + size_;
    size_ += count;
    return at;
}

void RecordBuffer::release_above(std::size_t most) {
    if (size_ == 0 && capacity_ > most) {
        bytes_.reset();
        capacity_ = 0;
    }
}

/// One direction's key: the traffic secret it came from (a KeyUpdate derives the next from it),
/// the AEAD context keyed once, the IV, and the number of the next record.
struct TlsRecords::Direction {
    const EVP_MD* digest;
    const EVP_CIPHER* cipher;
    bool encrypting;
    proto::Bytes secret;
    std::array<std::uint8_t, nonce_size> iv{};
    EVP_CIPHER_CTX* context;
    std::uint64_t sequence = 0;

    Direction(const EVP_MD* digest_, const EVP_CIPHER* cipher_, bool encrypting_, proto::ByteView secret_)
        : digest(digest_),
          cipher(cipher_),
          encrypting(encrypting_),
          secret(secret_.begin(), secret_.end()),
          context(::EVP_CIPHER_CTX_new()) {
        if (!context)
            throw std::runtime_error("OpenSSL could not make a cipher context");
        rekey();
    }
    ~Direction() {
        ::EVP_CIPHER_CTX_free(context);
        cleanse(secret);
    }
    Direction(const Direction&) = delete;
    Direction& operator=(const Direction&) = delete;

    void rekey() {
        proto::Bytes key = expand_label(digest, secret, "key",
                                        static_cast<std::size_t>(::EVP_CIPHER_get_key_length(cipher)));
        const proto::Bytes iv_bytes = expand_label(digest, secret, "iv", nonce_size);
        std::copy(iv_bytes.begin(), iv_bytes.end(), iv.begin());
        const bool keyed = encrypting
                               ? ::EVP_EncryptInit_ex(context, cipher, nullptr, key.data(), nullptr) == 1
                               : ::EVP_DecryptInit_ex(context, cipher, nullptr, key.data(), nullptr) == 1;
        cleanse(key);
        if (!keyed)
            throw std::runtime_error("OpenSSL could not key a TLS 1.3 record cipher");
        sequence = 0;
    }

    /// application_traffic_secret_N+1 (RFC 8446, section 7.2).
    void next_key() {
        proto::Bytes next = expand_label(digest, secret, "traffic upd", secret.size());
        cleanse(secret);
        secret = std::move(next);
        rekey();
    }

    /// The per-record nonce: the record's number, padded to the IV's length, XORed into the IV.
    std::array<std::uint8_t, nonce_size> nonce() const {
        auto nonce = iv;
        for (int i = 0; i < 8; ++i)
            nonce[nonce_size - 1 - static_cast<std::size_t>(i)] ^=
                static_cast<std::uint8_t>(sequence >> (8 * i));
        return nonce;
    }
};

TlsRecords::TlsRecords(std::unique_ptr<Direction> sending, std::unique_ptr<Direction> reading,
                       std::uint64_t records_per_key)
    : sending_(std::move(sending)), reading_(std::move(reading)), records_per_key_(records_per_key) {}

TlsRecords::~TlsRecords() = default;

std::unique_ptr<TlsRecords> TlsRecords::after_handshake(SSL* session, const TrafficSecrets& secrets,
                                                        std::uint64_t records_per_key) {
    const SSL_CIPHER* suite = ::SSL_get_current_cipher(session);
    if (!suite || ::SSL_version(session) != TLS1_3_VERSION)
        return nullptr;
    const bool server = ::SSL_is_server(session) == 1;
    return from_secrets(::SSL_CIPHER_get_protocol_id(suite), server ? secrets.server : secrets.client,
                        server ? secrets.client : secrets.server, records_per_key);
}

std::unique_ptr<TlsRecords> TlsRecords::from_secrets(std::uint16_t suite, proto::ByteView sending,
                                                     proto::ByteView reading, std::uint64_t records_per_key) {
    const EVP_CIPHER* cipher = nullptr;
    const EVP_MD* digest = nullptr;
    switch (suite) {
        case 0x1301:
            cipher = ::EVP_aes_128_gcm();
            digest = ::EVP_sha256();
            break;
        case 0x1302:
            cipher = ::EVP_aes_256_gcm();
            digest = ::EVP_sha384();
            break;
        case 0x1303:
            cipher = ::EVP_chacha20_poly1305();
            digest = ::EVP_sha256();
            break;
        default:
            return nullptr;
    }
    const auto secret_size = static_cast<std::size_t>(::EVP_MD_get_size(digest));
    if (sending.size() != secret_size || reading.size() != secret_size)
        return nullptr;
    return std::unique_ptr<TlsRecords>(
        new TlsRecords(std::make_unique<Direction>(digest, cipher, true, sending),
                       std::make_unique<Direction>(digest, cipher, false, reading), records_per_key));
}

void TlsRecords::seal(std::span<const proto::ByteView> pieces, RecordBuffer& out) {
    std::size_t left = 0;
    for (const auto& piece : pieces)
        left += piece.size();
    Cursor cursor{pieces};
    while (left > 0) {
        if (sending_->sequence >= records_per_key_)
            seal_key_update(false, out);
        const std::size_t size = std::min(left, max_plain);
        seal_record(application_data_type, cursor, size, out);
        left -= size;
    }
}

void TlsRecords::seal_content(std::uint8_t type, proto::ByteView content, RecordBuffer& out) {
    Cursor cursor{std::span(&content, 1)};
    seal_record(type, cursor, std::min(content.size(), max_plain), out);
}

void TlsRecords::seal_alert(std::uint8_t description, RecordBuffer& out) {
    const std::array<std::uint8_t, 2> alert{2, description};  // level "fatal"
    const proto::ByteView piece(alert);
    Cursor cursor{std::span(&piece, 1)};
    seal_record(alert_type, cursor, alert.size(), out);
}

void TlsRecords::answer_key_update(RecordBuffer& out) {
    if (!owe_key_update_)
        return;
    owe_key_update_ = false;
    seal_key_update(false, out);
}

void TlsRecords::request_key_update(RecordBuffer& out) {
    seal_key_update(true, out);
}

void TlsRecords::seal_key_update(bool request, RecordBuffer& out) {
    const std::array<std::uint8_t, 5> message{key_update, 0, 0, 1,
                                              static_cast<std::uint8_t>(request ? 1 : 0)};
    const proto::ByteView piece(message);
    Cursor cursor{std::span(&piece, 1)};
    seal_record(handshake_type, cursor, message.size(), out);
    sending_->next_key();  // the KeyUpdate itself went under the old key
}

void TlsRecords::seal_record(std::uint8_t type, Cursor& cursor, std::size_t size, RecordBuffer& out) {
    const std::size_t length = size + 1 + tag_size;  // the content, its type, the tag
    std::uint8_t* header = out.append(header_size + length);
    header[0] = application_data_type;  // every protected record says so (the true type is inside)
    header[1] = 3;
    header[2] = 3;
    header[3] = static_cast<std::uint8_t>(length >> 8);
    header[4] = static_cast<std::uint8_t>(length);
    std::uint8_t* body = header + header_size;
    EVP_CIPHER_CTX* context = sending_->context;
    const auto nonce = sending_->nonce();
    int n = 0;
    std::size_t written = 0;
    // Each call fails only on arguments this code controls (a keyed context, sizes under 2^31):
    // a failure is a bug, not a peer's doing.
    bool sealed = ::EVP_EncryptInit_ex(context, nullptr, nullptr, nullptr, nonce.data()) == 1 &&
                  ::EVP_EncryptUpdate(context, nullptr, &n, header, static_cast<int>(header_size)) == 1;
    for (std::size_t left = size; sealed && left > 0;) {
        const proto::ByteView piece = cursor.pieces[cursor.index];
        const std::size_t take = std::min(left, piece.size() - cursor.offset);
        sealed = ::EVP_EncryptUpdate(context, body + written, &n, piece.data() + cursor.offset,
                                     static_cast<int>(take)) == 1;
        written += static_cast<std::size_t>(n);
        left -= take;
        cursor.offset += take;
        if (cursor.offset == piece.size()) {
            ++cursor.index;
            cursor.offset = 0;
        }
    }
    sealed = sealed && ::EVP_EncryptUpdate(context, body + written, &n, &type, 1) == 1;
    written += static_cast<std::size_t>(n);
    sealed = sealed && ::EVP_EncryptFinal_ex(context, body + written, &n) == 1;
    written += static_cast<std::size_t>(n);
    sealed = sealed && written == size + 1 &&
             ::EVP_CIPHER_CTX_ctrl(context, EVP_CTRL_AEAD_GET_TAG, static_cast<int>(tag_size),
                                   body + written) == 1;
    if (!sealed)
        throw std::runtime_error("OpenSSL failed to seal a TLS record");
    ++sending_->sequence;
}

TlsRecords::Framing TlsRecords::frame(proto::ByteView bytes) {
    if (bytes.size() < header_size)
        return {};
    if (bytes[0] != application_data_type)  // after the handshake every record is protected
        return {0, tls_reason(SSL_R_UNEXPECTED_RECORD), SSL_AD_UNEXPECTED_MESSAGE};
    if (bytes[1] != 3 || bytes[2] != 3)
        return {0, tls_reason(SSL_R_WRONG_VERSION_NUMBER), SSL_AD_PROTOCOL_VERSION};
    const std::size_t length = std::size_t{bytes[3]} << 8 | bytes[4];
    if (header_size + length > max_record)
        return {0, tls_reason(SSL_R_ENCRYPTED_LENGTH_TOO_LONG), SSL_AD_RECORD_OVERFLOW};
    if (length < tag_size + 1)  // no room for a tag and a content type: it cannot open
        return {0, tls_reason(SSL_R_DECRYPTION_FAILED_OR_BAD_RECORD_MAC), SSL_AD_BAD_RECORD_MAC};
    return {bytes.size() >= header_size + length ? header_size + length : 0, {}, 0};
}

TlsRecords::Opened TlsRecords::open(std::span<std::uint8_t> record, std::uint8_t* out) {
    const std::size_t sealed = record.size() - header_size - tag_size;
    EVP_CIPHER_CTX* context = reading_->context;
    const auto nonce = reading_->nonce();
    int n = 0;
    const bool opened =
        ::EVP_DecryptInit_ex(context, nullptr, nullptr, nullptr, nonce.data()) == 1 &&
        ::EVP_DecryptUpdate(context, nullptr, &n, record.data(), static_cast<int>(header_size)) == 1 &&
        ::EVP_DecryptUpdate(context, out, &n, record.data() + header_size, static_cast<int>(sealed)) == 1 &&
        ::EVP_CIPHER_CTX_ctrl(context, EVP_CTRL_AEAD_SET_TAG, static_cast<int>(tag_size),
                              record.data() + header_size + sealed) == 1 &&
        // The tag is checked here, in constant time, by OpenSSL.
        ::EVP_DecryptFinal_ex(context, out + n, &n) == 1;
    ::ERR_clear_error();
    if (!opened)
        return {0, false, tls_reason(SSL_R_DECRYPTION_FAILED_OR_BAD_RECORD_MAC), SSL_AD_BAD_RECORD_MAC};
    ++reading_->sequence;
    // The content is followed by its type and any zeros the sender padded with.
    std::size_t end = sealed;
    while (end > 0 && out[end - 1] == 0)
        --end;
    if (end == 0)
        return {0, false, tls_reason(SSL_R_UNEXPECTED_MESSAGE), SSL_AD_UNEXPECTED_MESSAGE};
    const std::uint8_t type = out[end - 1];
    const std::size_t content = end - 1;
    if (content > max_plain)
        return {0, false, tls_reason(SSL_R_DATA_LENGTH_TOO_LONG), SSL_AD_RECORD_OVERFLOW};
    switch (type) {
        case application_data_type:
            return {content, false, {}, 0};
        case alert_type:
            if (content != 2)
                return {0, false, tls_reason(SSL_R_BAD_LENGTH), SSL_AD_DECODE_ERROR};
            if (out[1] == close_notify)
                return {0, true, {}, 0};
            if (out[1] == user_canceled)  // a warning that a close follows
                return {};
            return {0, false, tls_reason(SSL_AD_REASON_OFFSET + out[1]), 0};
        case handshake_type:
            return take_handshake({out, content});
        default:
            return {0, false, tls_reason(SSL_R_UNEXPECTED_RECORD), SSL_AD_UNEXPECTED_MESSAGE};
    }
}

TlsRecords::Opened TlsRecords::take_handshake(proto::ByteView messages) {
    while (!messages.empty()) {
        if (messages.size() < 4)  // a message split across records: no peer of ours sends one
            return {0, false, tls_reason(SSL_R_UNEXPECTED_MESSAGE), SSL_AD_UNEXPECTED_MESSAGE};
        const std::size_t length =
            std::size_t{messages[1]} << 16 | std::size_t{messages[2]} << 8 | messages[3];
        if (messages.size() < 4 + length)
            return {0, false, tls_reason(SSL_R_UNEXPECTED_MESSAGE), SSL_AD_UNEXPECTED_MESSAGE};
        const std::uint8_t type = messages[0];
        const proto::ByteView body = messages.subspan(4, length);
        messages = messages.subspan(4 + length);
        if (type == new_session_ticket)
            continue;  // this end never resumes a session
        if (type != key_update)
            return {0, false, tls_reason(SSL_R_UNEXPECTED_MESSAGE), SSL_AD_UNEXPECTED_MESSAGE};
        if (body.size() != 1 || body[0] > 1)
            return {0, false, tls_reason(SSL_R_BAD_KEY_UPDATE), SSL_AD_ILLEGAL_PARAMETER};
        if (!messages.empty())  // the key changes after this message: nothing may follow it here
            return {0, false, tls_reason(SSL_R_NOT_ON_RECORD_BOUNDARY), SSL_AD_UNEXPECTED_MESSAGE};
        reading_->next_key();
        owe_key_update_ = owe_key_update_ || body[0] == 1;
    }
    return {};
}

}  // namespace plexus::daemon
