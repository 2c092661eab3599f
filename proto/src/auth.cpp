#include "plexus/proto/auth.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <fstream>
#include <iterator>
#include <stdexcept>

// SHA256_Init/Update/Final are deprecated in OpenSSL 3 in favour of EVP_Digest*, which dispatch
// through providers and allocate when a context is copied: the datagram MAC needs the plain
// struct (see Secret::Keys). They remain in libcrypto 3 with the same code behind them.
#define OPENSSL_SUPPRESS_DEPRECATED
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>
#include <openssl/sha.h>

namespace plexus::proto {

namespace {
constexpr std::string_view connecting_label = "plexus-auth-v1 connecting";
constexpr std::string_view accepting_label = "plexus-auth-v1 accepting";
constexpr std::string_view datagram_label = "plexus-datagram-v1";
constexpr std::string_view web_token_label = "plexus web token v1";
constexpr std::string_view tls_key_label = "plexus tls psk v1";

Proof hmac(ByteView key, std::initializer_list<ByteView> parts) {
    // One HMAC over the concatenation; the parts are short, so joining them costs nothing.
    Bytes message;
    for (const auto& part : parts)
        message.insert(message.end(), part.begin(), part.end());
    Proof out{};
    unsigned int size = 0;
    ::HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()), message.data(), message.size(), out.data(),
           &size);
    return out;
}

Bytes length_prefixed(std::string_view text) {
    Bytes out(2 + text.size());
    out[0] = static_cast<std::uint8_t>(text.size() >> 8);
    out[1] = static_cast<std::uint8_t>(text.size());
    std::copy(text.begin(), text.end(), out.begin() + 2);
    return out;
}
}  // namespace

struct Secret::Keys {
    Bytes proof_key;     ///< the secret itself: proofs are HMACs keyed by it
    Proof datagram_key;  ///< HMAC(secret, datagram label): datagrams never use the secret directly
    /// HMAC-SHA256 keyed with datagram_key, its two padded key blocks already hashed: a datagram's
    /// MAC starts from copies of these (plain structs), then hashes only the datagram and the
    /// inner digest. OpenSSL 3's EVP_MAC did the same work through provider calls and two context
    /// copies (each an allocation) per datagram; over the hosts' udp ping-pong that cost +10% of
    /// the 64 B latency (~6 us for the four MACs of a round trip), against -2..-4% with the MAC
    /// left out (the A/A noise). Read-only once made, so threads share them without a lock.
    SHA256_CTX inner{};
    SHA256_CTX outer{};
};

namespace {
void start_hmac_sha256(ByteView key, SHA256_CTX& inner, SHA256_CTX& outer) {
    constexpr std::size_t block = 64;
    std::array<std::uint8_t, block> padded{};
    if (key.size() > block)
        ::SHA256(key.data(), key.size(), padded.data());
    else
        std::copy(key.begin(), key.end(), padded.begin());
    std::array<std::uint8_t, block> pad{};
    for (std::size_t i = 0; i < block; ++i)
        pad[i] = padded[i] ^ 0x36;
    ::SHA256_Init(&inner);
    ::SHA256_Update(&inner, pad.data(), pad.size());
    for (std::size_t i = 0; i < block; ++i)
        pad[i] = padded[i] ^ 0x5c;
    ::SHA256_Init(&outer);
    ::SHA256_Update(&outer, pad.data(), pad.size());
    ::OPENSSL_cleanse(padded.data(), padded.size());
    ::OPENSSL_cleanse(pad.data(), pad.size());
}
}  // namespace

Result<Secret> Secret::from_bytes(std::string_view bytes) {
    if (bytes.size() < min_secret_size) {
        return Error{"the secret is " + std::to_string(bytes.size()) + " bytes; at least " +
                     std::to_string(min_secret_size) +
                     " are needed (e.g. `head -c 32 /dev/urandom | base64`)"};
    }
    auto keys = std::make_shared<Keys>();
    keys->proof_key.assign(bytes.begin(), bytes.end());
    keys->datagram_key = hmac(keys->proof_key, {as_bytes(datagram_label)});
    start_hmac_sha256(keys->datagram_key, keys->inner, keys->outer);
    Secret secret;
    secret.keys_ = std::move(keys);
    return secret;
}

Result<Secret> Secret::load(const std::string& path) {
    struct stat info {};
    if (::stat(path.c_str(), &info) != 0)
        return Error{"cannot read the secret file " + path};
    if ((info.st_mode & (S_IRWXG | S_IRWXO)) != 0)
        return Error{"the secret file " + path + " is readable by others: chmod 600 " + path};
    std::ifstream in(path, std::ios::binary);
    if (!in)
        return Error{"cannot read the secret file " + path};
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!bytes.empty() && bytes.back() == '\n')
        bytes.pop_back();
    auto secret = from_bytes(bytes);
    if (!secret)
        return Error{"secret file " + path + ": " + secret.error().message};
    return secret;
}

Proof Secret::prove(Party party, const Nonce& challenge, const Nonce& own, std::string_view role,
                    std::string_view node) const {
    const auto label = party == Party::connecting ? connecting_label : accepting_label;
    return hmac(keys_->proof_key,
                {as_bytes(label), challenge, own, length_prefixed(role), length_prefixed(node)});
}

void Secret::datagram_mac(ByteView head, ByteView body, std::uint8_t* out16) const {
    SHA256_CTX context = keys_->inner;
    ::SHA256_Update(&context, head.data(), head.size());
    if (!body.empty())
        ::SHA256_Update(&context, body.data(), body.size());
    Proof digest{};
    ::SHA256_Final(digest.data(), &context);
    context = keys_->outer;
    ::SHA256_Update(&context, digest.data(), digest.size());
    ::SHA256_Final(digest.data(), &context);
    std::copy_n(digest.begin(), 16, out16);
}

bool Secret::datagram_mac_ok(ByteView signed_part, ByteView mac) const {
    if (mac.size() != 16)
        return false;
    std::uint8_t expected[16];
    datagram_mac(signed_part, expected);
    return ::CRYPTO_memcmp(expected, mac.data(), 16) == 0;
}

Nonce random_nonce() {
    Nonce nonce{};
    if (::RAND_bytes(nonce.data(), static_cast<int>(nonce.size())) != 1)
        throw std::runtime_error("no random numbers from the kernel (RAND_bytes failed)");
    return nonce;
}

bool same_proof(const Proof& a, ByteView b) {
    return b.size() == a.size() && ::CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

bool same_text(std::string_view a, std::string_view b) {
    // The length is not secret (every token has 64 characters); the bytes are.
    return a.size() == b.size() && ::CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

Proof Secret::tls_key() const {
    return hmac(keys_->proof_key, {as_bytes(tls_key_label)});
}

std::string Secret::web_token() const {
    const Proof mac = hmac(keys_->proof_key, {as_bytes(web_token_label)});
    static constexpr char digits[] = "0123456789abcdef";
    std::string hex;
    hex.reserve(mac.size() * 2);
    for (const std::uint8_t byte : mac) {
        hex.push_back(digits[byte >> 4]);
        hex.push_back(digits[byte & 0x0f]);
    }
    return hex;
}

}  // namespace plexus::proto
