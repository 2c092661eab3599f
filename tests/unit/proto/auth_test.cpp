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

TEST(Auth_test, TheTlsKeyIsTheDocumentedHmac) {
    // PROTOCOL.md: HMAC-SHA256(secret, "plexus tls psk v1"), here with OpenSSL's one-shot HMAC.
    const std::string secret_bytes = "0123456789abcdef-secret";
    const std::string label = "plexus tls psk v1";
    std::uint8_t expected[32];
    unsigned int size = 0;
    ::HMAC(EVP_sha256(), secret_bytes.data(), static_cast<int>(secret_bytes.size()),
           reinterpret_cast<const std::uint8_t*>(label.data()), label.size(), expected, &size);
    const auto key = secret_of(secret_bytes).tls_key();
    EXPECT_EQ(Bytes(key.begin(), key.end()), Bytes(expected, expected + 32));
    EXPECT_NE(secret_of("another-secret-of-16").tls_key(), key);
}

TEST(Auth_test, ADiscoveryProofBindsTheSecretTheNonceAndTheAddress) {
    const auto secret = secret_of("0123456789abcdef-secret");
    const auto proof = secret.discovery_proof("nonce-1", "10.0.0.1:10100");
    EXPECT_EQ(proof.size(), 64u);
    EXPECT_TRUE(same_text(proof, secret.discovery_proof("nonce-1", "10.0.0.1:10100")));
    EXPECT_FALSE(same_text(proof, secret.discovery_proof("nonce-2", "10.0.0.1:10100")));
    EXPECT_FALSE(same_text(proof, secret.discovery_proof("nonce-1", "10.0.0.2:10100")));
    EXPECT_FALSE(
        same_text(proof, secret_of("another-secret-of-16").discovery_proof("nonce-1", "10.0.0.1:10100")));
    // The parts cannot run into each other.
    EXPECT_FALSE(same_text(secret.discovery_proof("ab", "c"), secret.discovery_proof("a", "bc")));
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
    EXPECT_EQ(loaded->tls_key(), secret_of("a-secret-long-enough-for-this").tls_key());
    ::chmod(path, 0644);
    auto open = Secret::load(path);
    ASSERT_FALSE(open);
    EXPECT_NE(open.error().message.find("readable by others"), std::string::npos) << open.error().message;
    std::remove(path);
    EXPECT_FALSE(Secret::load(path));
}

}  // namespace
}  // namespace plexus::proto
