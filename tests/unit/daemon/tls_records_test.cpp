// TlsRecords against OpenSSL's own record layer, over one real handshake each: what this end seals,
// OpenSSL reads, and what OpenSSL writes, this end opens (libplexus keeps OpenSSL's records, so the
// two must be the same TLS 1.3). Both roles, key updates both ways, and what a man in the middle
// might do to a record.

#include <gtest/gtest.h>
#include <openssl/bio.h>
#include <openssl/err.h>
#include <openssl/ssl.h>

#include <string>
#include <vector>

#include "net/tls_records.hpp"
#include "plexus/proto/auth.hpp"
#include "plexus/proto/tls_psk.hpp"

namespace plexus::daemon {
namespace tls_records_test {
namespace {

proto::Bytes bytes_of(const std::string& text) {
    return {text.begin(), text.end()};
}

proto::Bytes pattern(std::size_t size, std::uint8_t seed) {
    proto::Bytes bytes(size);
    for (std::size_t i = 0; i < size; ++i)
        bytes[i] = static_cast<std::uint8_t>(seed + i * 7 + i / 251);
    return bytes;
}

/// One TLS session driven over memory BIOs: `in` takes the peer's bytes, `out` holds its own.
struct Side {
    SSL* ssl = nullptr;
    BIO* in = nullptr;
    BIO* out = nullptr;
    Side(SSL_CTX* context, bool accepting) : ssl(::SSL_new(context)) {
        in = ::BIO_new(::BIO_s_mem());
        out = ::BIO_new(::BIO_s_mem());
        BIO_set_mem_eof_return(in, -1);
        ::SSL_set_bio(ssl, in, out);
        if (accepting)
            ::SSL_set_accept_state(ssl);
        else
            ::SSL_set_connect_state(ssl);
    }
    ~Side() { ::SSL_free(ssl); }
    proto::Bytes take_output() const {
        proto::Bytes bytes(static_cast<std::size_t>(BIO_pending(out)));
        if (!bytes.empty())
            ::BIO_read(out, bytes.data(), static_cast<int>(bytes.size()));
        return bytes;
    }
    void give(proto::ByteView bytes) const {
        if (!bytes.empty())
            ::BIO_write(in, bytes.data(), static_cast<int>(bytes.size()));
    }
    /// Every plain byte OpenSSL can read from what it was given.
    proto::Bytes read_all() const {
        proto::Bytes plain;
        std::uint8_t buffer[4096];
        for (;;) {
            const int n = ::SSL_read(ssl, buffer, sizeof buffer);
            if (n <= 0)
                return plain;
            plain.insert(plain.end(), buffer, buffer + n);
        }
    }
};

/// A handshake between this end ("ours", whose secrets are captured) and OpenSSL ("theirs"), both
/// keyed by one deployment secret, as two daemons' links are.
class TlsRecordsTest : public ::testing::TestWithParam<bool> {
protected:
    void SetUp() override {
        auto secret = proto::Secret::from_bytes("a deployment secret long enough to be one");
        ASSERT_TRUE(secret);
        our_context_ = proto::new_link_tls_context(*secret);
        their_context_ = proto::new_link_tls_context(*secret);
        capture_traffic_secrets(our_context_);
        const bool we_accept = GetParam();
        ours_ = std::make_unique<Side>(our_context_, we_accept);
        theirs_ = std::make_unique<Side>(their_context_, !we_accept);
        attach_traffic_secrets(ours_->ssl, &secrets_);
        bool our_done = false;
        bool their_done = false;
        for (int round = 0; round < 20 && !(our_done && their_done); ++round) {
            our_done = our_done || ::SSL_do_handshake(ours_->ssl) == 1;
            theirs_->give(ours_->take_output());
            their_done = their_done || ::SSL_do_handshake(theirs_->ssl) == 1;
            ours_->give(theirs_->take_output());
        }
        ASSERT_TRUE(our_done && their_done) << proto::last_tls_error();
        records_ = TlsRecords::after_handshake(ours_->ssl, secrets_, records_per_key());
        ASSERT_NE(records_, nullptr);
        // What OpenSSL received after its handshake but has not read stays in `in`: ours reads it.
        pending_ = proto::Bytes(static_cast<std::size_t>(BIO_pending(ours_->in)));
        if (!pending_.empty())
            ::BIO_read(ours_->in, pending_.data(), static_cast<int>(pending_.size()));
    }
    void TearDown() override {
        ours_.reset();
        theirs_.reset();
        ::SSL_CTX_free(our_context_);
        ::SSL_CTX_free(their_context_);
    }
    virtual std::uint64_t records_per_key() const { return TlsRecords::default_records_per_key; }

    /// Hands OpenSSL's output since the last call to ours and opens every record in it.
    struct Opened {
        proto::Bytes plain;
        bool closed = false;
        boost::system::error_code error;
        std::uint8_t alert = 0;
    };
    Opened open_theirs() {
        auto bytes = theirs_->take_output();
        pending_.insert(pending_.end(), bytes.begin(), bytes.end());
        return open_pending();
    }
    Opened open_pending() {
        Opened result;
        std::size_t at = 0;
        for (;;) {
            const auto framing = TlsRecords::frame(proto::ByteView(pending_).subspan(at));
            if (framing.error) {
                result.error = framing.error;
                result.alert = framing.alert;
                break;
            }
            if (framing.size == 0)
                break;
            std::span record(pending_.data() + at, framing.size);
            proto::Bytes out(framing.size);
            const auto opened = records_->open(record, out.data());
            at += framing.size;
            if (opened.error || opened.closed) {
                result.error = opened.error;
                result.alert = opened.alert;
                result.closed = opened.closed;
                break;
            }
            result.plain.insert(result.plain.end(), out.begin(),
                                out.begin() + static_cast<std::ptrdiff_t>(opened.plain));
        }
        pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(at));
        return result;
    }
    /// Seals `pieces` with ours, gives the records to OpenSSL and returns what it reads.
    proto::Bytes seal_and_read(const std::vector<proto::Bytes>& pieces) {
        std::vector<proto::ByteView> views(pieces.begin(), pieces.end());
        RecordBuffer sealed;
        records_->seal(views, sealed);
        theirs_->give(proto::ByteView(sealed.data(), sealed.size()));
        return theirs_->read_all();
    }

    SSL_CTX* our_context_ = nullptr;
    SSL_CTX* their_context_ = nullptr;
    std::unique_ptr<Side> ours_;
    std::unique_ptr<Side> theirs_;
    TrafficSecrets secrets_;
    std::unique_ptr<TlsRecords> records_;
    proto::Bytes pending_;
};

TEST_P(TlsRecordsTest, WhatThisEndSealsOpenSslReadsSmallPiecesSharingARecordAndLargeOnesSplit) {
    const std::vector<proto::Bytes> pieces{
        bytes_of("a frame"), pattern(40'000, 3), bytes_of("another"), pattern(16 * 1024, 9), {},
        bytes_of("z")};
    proto::Bytes expected;
    for (const auto& piece : pieces)
        expected.insert(expected.end(), piece.begin(), piece.end());
    EXPECT_EQ(seal_and_read(pieces), expected);
    // And again: the record numbers go on.
    EXPECT_EQ(seal_and_read({bytes_of("more")}), bytes_of("more"));
}

TEST_P(TlsRecordsTest, WhatOpenSslWritesThisEndOpens) {
    const proto::Bytes large = pattern(50'000, 1);
    // The context writes partially (a record at a time), as a daemon's does.
    for (std::size_t at = 0; at < large.size();) {
        const int n = ::SSL_write(theirs_->ssl, large.data() + at, static_cast<int>(large.size() - at));
        ASSERT_GT(n, 0);
        at += static_cast<std::size_t>(n);
    }
    ASSERT_EQ(::SSL_write(theirs_->ssl, "tail", 4), 4);
    auto opened = open_theirs();
    EXPECT_FALSE(opened.error) << opened.error.message();
    proto::Bytes expected = large;
    expected.insert(expected.end(), {'t', 'a', 'i', 'l'});
    EXPECT_EQ(opened.plain, expected);
}

TEST_P(TlsRecordsTest, AKeyUpdateOpenSslAsksForIsTakenAndAnswered) {
    ASSERT_EQ(::SSL_key_update(theirs_->ssl, SSL_KEY_UPDATE_REQUESTED), 1);
    ASSERT_EQ(::SSL_write(theirs_->ssl, "after", 5), 5);
    auto opened = open_theirs();
    EXPECT_FALSE(opened.error) << opened.error.message();
    EXPECT_EQ(opened.plain, bytes_of("after"));
    ASSERT_TRUE(records_->owes_key_update());
    RecordBuffer answer;
    records_->answer_key_update(answer);
    EXPECT_FALSE(records_->owes_key_update());
    theirs_->give(proto::ByteView(answer.data(), answer.size()));
    // OpenSSL takes the answer and reads what ours sealed under its new key.
    EXPECT_EQ(seal_and_read({bytes_of("under the new key")}), bytes_of("under the new key"));
    ASSERT_EQ(::SSL_write(theirs_->ssl, "and back", 8), 8);
    EXPECT_EQ(open_theirs().plain, bytes_of("and back"));
}

TEST_P(TlsRecordsTest, AlteredReplayedOrForgedRecordsAreRefusedAsBadRecordMacs) {
    ASSERT_EQ(::SSL_write(theirs_->ssl, "first", 5), 5);
    auto record = theirs_->take_output();
    // Altered: one bit of the ciphertext.
    auto altered = record;
    altered[TlsRecords::header_size + 2] ^= 0x01;
    pending_ = altered;
    auto opened = open_pending();
    EXPECT_EQ(opened.error, tls_reason(SSL_R_DECRYPTION_FAILED_OR_BAD_RECORD_MAC));
    EXPECT_EQ(opened.alert, SSL_AD_BAD_RECORD_MAC);
    EXPECT_TRUE(opened.plain.empty());
}

TEST_P(TlsRecordsTest, ARecordOpensOnceAndNotAgain) {
    ASSERT_EQ(::SSL_write(theirs_->ssl, "once", 4), 4);
    const auto record = theirs_->take_output();
    pending_ = record;
    EXPECT_EQ(open_pending().plain, bytes_of("once"));
    pending_ = record;  // replayed: its number is behind
    EXPECT_EQ(open_pending().error, tls_reason(SSL_R_DECRYPTION_FAILED_OR_BAD_RECORD_MAC));
}

TEST_P(TlsRecordsTest, TheAlertThisEndSendsEndsOpenSslsSessionAndItsCloseNotifyEndsOurs) {
    RecordBuffer alert;
    records_->seal_alert(SSL_AD_BAD_RECORD_MAC, alert);
    theirs_->give(proto::ByteView(alert.data(), alert.size()));
    char buffer[16];
    EXPECT_LE(::SSL_read(theirs_->ssl, buffer, sizeof buffer), 0);
    const unsigned long reason = ::ERR_peek_last_error();
    ::ERR_clear_error();
    EXPECT_EQ(ERR_GET_REASON(reason), SSL_AD_REASON_OFFSET + SSL_AD_BAD_RECORD_MAC) << reason;
}

TEST_P(TlsRecordsTest, OpenSslsCloseNotifyReadsAsAClose) {
    ASSERT_GE(::SSL_shutdown(theirs_->ssl), 0);
    EXPECT_TRUE(open_theirs().closed);
}

TEST_P(TlsRecordsTest, AnAlertFromOpenSslIsThePeersNotTampering) {
    // OpenSSL sends an alert when it finds a record that fails: give it one.
    RecordBuffer sealed;
    const proto::ByteView piece(reinterpret_cast<const std::uint8_t*>("x"), 1);
    records_->seal(std::span(&piece, 1), sealed);
    sealed.data()[sealed.size() - 1] ^= 0x80;
    theirs_->give(proto::ByteView(sealed.data(), sealed.size()));
    char buffer[16];
    EXPECT_LE(::SSL_read(theirs_->ssl, buffer, sizeof buffer), 0);
    ::ERR_clear_error();
    const auto opened = open_theirs();
    ASSERT_TRUE(opened.error);
    EXPECT_EQ(ERR_GET_REASON(static_cast<unsigned long>(opened.error.value())),
              SSL_AD_REASON_OFFSET + SSL_AD_BAD_RECORD_MAC);
    EXPECT_EQ(opened.alert, 0);  // no alert answers an alert
}

TEST_P(TlsRecordsTest, ImpossibleHeadersAreRefusedBeforeAnythingIsOpened) {
    EXPECT_EQ(TlsRecords::frame(bytes_of("\x17\x03")).size, 0u);  // not all here yet
    const proto::Bytes handshake{22, 3, 3, 0, 40};
    EXPECT_EQ(TlsRecords::frame(handshake).error, tls_reason(SSL_R_UNEXPECTED_RECORD));
    const proto::Bytes too_long{23, 3, 3, 0x41, 0x01};  // 16,641 bytes: past 2^14 + 256
    EXPECT_EQ(TlsRecords::frame(too_long).error, tls_reason(SSL_R_ENCRYPTED_LENGTH_TOO_LONG));
    const proto::Bytes too_short{23, 3, 3, 0, 16};  // no room for a tag and a content type
    EXPECT_EQ(TlsRecords::frame(too_short).error, tls_reason(SSL_R_DECRYPTION_FAILED_OR_BAD_RECORD_MAC));
    const proto::Bytes old_version{23, 3, 1, 0, 40};
    EXPECT_EQ(TlsRecords::frame(old_version).error, tls_reason(SSL_R_WRONG_VERSION_NUMBER));
}

INSTANTIATE_TEST_SUITE_P(Roles, TlsRecordsTest, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "accepting" : "connecting"; });

/// A key used for two records only: this end moves to the next key on its own, and OpenSSL follows.
class TlsRecordsShortKeysTest : public TlsRecordsTest {
protected:
    std::uint64_t records_per_key() const override { return 2; }
};

TEST_P(TlsRecordsShortKeysTest, ThisEndUpdatesItsKeyAfterSoManyRecordsAndOpenSslFollows) {
    const proto::Bytes large = pattern(5 * TlsRecords::max_plain + 10, 5);  // six records, two updates
    EXPECT_EQ(seal_and_read({large}), large);
    EXPECT_EQ(seal_and_read({bytes_of("still")}), bytes_of("still"));
}

INSTANTIATE_TEST_SUITE_P(Roles, TlsRecordsShortKeysTest, ::testing::Values(false, true),
                         [](const auto& info) { return info.param ? "accepting" : "connecting"; });

}  // namespace
}  // namespace tls_records_test
}  // namespace plexus::daemon
