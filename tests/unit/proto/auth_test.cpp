#include "plexus/proto/auth.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include <openssl/evp.h>
#include <openssl/hmac.h>

namespace plexus::proto {
namespace {

Secret secret_of(std::string_view bytes) {
    auto secret = Secret::from_bytes(bytes);
    EXPECT_TRUE(secret) << secret.error().message;
    return *secret;
}

TEST(Auth_test, AProofHoldsOnlyForItsNoncesRoleNodeAndSecret) {
    const auto secret = secret_of("0123456789abcdef-secret");
    const auto a = random_nonce();
    const auto b = random_nonce();
    EXPECT_NE(a, b);
    const auto proof = secret.prove(Party::connecting, a, b, "daemon", "arm");
    EXPECT_TRUE(same_proof(proof, secret.prove(Party::connecting, a, b, "daemon", "arm")));
    EXPECT_FALSE(same_proof(proof, secret.prove(Party::connecting, b, a, "daemon", "arm")));
    EXPECT_FALSE(same_proof(proof, secret.prove(Party::connecting, a, b, "link", "arm")));
    EXPECT_FALSE(same_proof(proof, secret.prove(Party::connecting, a, b, "daemon", "head")));
    EXPECT_FALSE(
        same_proof(proof, secret_of("another-secret-of-16").prove(Party::connecting, a, b, "daemon", "arm")));
    // Role and node are length-prefixed: moving a byte from one to the other changes the proof.
    EXPECT_FALSE(same_proof(secret.prove(Party::connecting, a, b, "ab", "c"),
                            secret.prove(Party::connecting, a, b, "a", "bc")));
    EXPECT_FALSE(same_proof(proof, ByteView(proof).first(31)));
    // The other end's proof over the very same fields differs: it cannot be reflected back.
    EXPECT_FALSE(same_proof(proof, secret.prove(Party::accepting, a, b, "daemon", "arm")));
}

TEST(Auth_test, ADatagramMacFailsOnAnyChangedByte) {
    const auto secret = secret_of("0123456789abcdef-secret");
    Bytes datagram(100, 7);
    std::uint8_t mac[16];
    secret.datagram_mac(datagram, mac);
    EXPECT_TRUE(secret.datagram_mac_ok(datagram, {mac, 16}));
    for (std::size_t i = 0; i < datagram.size(); i += 13) {
        auto changed = datagram;
        changed[i] ^= 1;
        EXPECT_FALSE(secret.datagram_mac_ok(changed, {mac, 16})) << i;
    }
    EXPECT_FALSE(secret_of("another-secret-of-16").datagram_mac_ok(datagram, {mac, 16}));
    EXPECT_FALSE(secret.datagram_mac_ok(datagram, {mac, 15}));
}

TEST(Auth_test, ADatagramMacIsTheDocumentedHmacEveryTime) {
    // PROTOCOL.md: the first 16 bytes of HMAC-SHA256(HMAC-SHA256(secret, "plexus-datagram-v1"),
    // datagram), computed here with OpenSSL's one-shot HMAC. Repeated, because one context is
    // re-initialised for every datagram: nothing of one may leak into the next.
    const std::string secret_bytes = "0123456789abcdef-secret";
    const auto secret = secret_of(secret_bytes);
    const std::string label = "plexus-datagram-v1";
    std::uint8_t key[32];
    unsigned int size = 0;
    ::HMAC(EVP_sha256(), secret_bytes.data(), static_cast<int>(secret_bytes.size()),
           reinterpret_cast<const std::uint8_t*>(label.data()), label.size(), key, &size);
    for (std::size_t length : {1u, 100u, 1400u, 100u}) {
        Bytes datagram(length);
        for (std::size_t i = 0; i < length; ++i)
            datagram[i] = static_cast<std::uint8_t>(i * 31 + length);
        std::uint8_t expected[32];
        ::HMAC(EVP_sha256(), key, sizeof key, datagram.data(), datagram.size(), expected, &size);
        std::uint8_t mac[16];
        secret.datagram_mac(datagram, mac);
        EXPECT_EQ(Bytes(mac, mac + 16), Bytes(expected, expected + 16)) << length;
        // Head and body hashed as one.
        secret.datagram_mac(ByteView(datagram).first(length / 2), ByteView(datagram).subspan(length / 2),
                            mac);
        EXPECT_EQ(Bytes(mac, mac + 16), Bytes(expected, expected + 16)) << length;
    }
}

TEST(Auth_test, ShortSecretsAndOpenFilesAreRefused) {
    EXPECT_FALSE(Secret::from_bytes("short"));
    char path[] = "/tmp/plexus-secret-XXXXXX";
    const int fd = ::mkstemp(path);
    ASSERT_GE(fd, 0);
    const std::string text = "a-secret-long-enough-for-this\n";
    ASSERT_EQ(::write(fd, text.data(), text.size()), static_cast<ssize_t>(text.size()));
    ::close(fd);
    ::chmod(path, 0600);
    auto loaded = Secret::load(path);
    ASSERT_TRUE(loaded) << loaded.error().message;
    // The trailing newline is not part of the secret.
    const auto n = random_nonce();
    EXPECT_TRUE(
        same_proof(loaded->prove(Party::connecting, n, n, "r", "n"),
                   secret_of("a-secret-long-enough-for-this").prove(Party::connecting, n, n, "r", "n")));
    ::chmod(path, 0644);
    auto open = Secret::load(path);
    ASSERT_FALSE(open);
    EXPECT_NE(open.error().message.find("readable by others"), std::string::npos) << open.error().message;
    std::remove(path);
    EXPECT_FALSE(Secret::load(path));
}

}  // namespace
}  // namespace plexus::proto
