#include "plexus/proto/auth.hpp"

#include <sys/stat.h>

#include <fstream>
#include <iterator>

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>

#include "plexus/proto/hex.hpp"
#include "plexus/proto/identity.hpp"

namespace plexus::proto {

namespace {
constexpr std::string_view web_token_label = "plexus web token v1";
constexpr std::string_view tls_key_label = "plexus tls psk v1";
constexpr std::string_view discovery_label = "plexus discovery v1";

Digest hmac(ByteView key, std::initializer_list<ByteView> parts) {
    // One HMAC over the concatenation; the parts are short, so joining them costs nothing.
    Bytes message;
    for (const auto& part : parts)
        message.insert(message.end(), part.begin(), part.end());
    Digest out{};
    unsigned int size = 0;
    ::HMAC(EVP_sha256(), key.data(), static_cast<int>(key.size()), message.data(), message.size(), out.data(),
           &size);
    return out;
}

/// A part of an HMAC's message that cannot run into the next one: its length, then its bytes.
Bytes length_prefixed(std::string_view text) {
    Bytes out(2 + text.size());
    out[0] = static_cast<std::uint8_t>(text.size() >> 8);
    out[1] = static_cast<std::uint8_t>(text.size());
    std::copy(text.begin(), text.end(), out.begin() + 2);
    return out;
}
}  // namespace

Result<Secret> Secret::from_bytes(std::string_view bytes) {
    if (bytes.size() < min_secret_size) {
        return Error{"the secret is " + std::to_string(bytes.size()) + " bytes; at least " +
                     std::to_string(min_secret_size) +
                     " are needed (e.g. `head -c 32 /dev/urandom | base64`)"};
    }
    Secret secret;
    secret.secret_ = std::make_shared<const Bytes>(bytes.begin(), bytes.end());
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

bool same_text(std::string_view a, std::string_view b) {
    // The length is not secret (every token has 64 characters); the bytes are.
    return a.size() == b.size() && ::CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

void Secret::set_identity(const Identity& identity) {
    identity_ = std::make_shared<const Identity>(identity);
}

Digest Secret::tls_key() const {
    return hmac(*secret_, {as_bytes(tls_key_label)});
}

std::string Secret::web_token() const {
    return hex_text(hmac(*secret_, {as_bytes(web_token_label)}));
}

std::string Secret::discovery_proof(std::string_view nonce, std::string_view address) const {
    return hex_text(
        hmac(*secret_, {as_bytes(discovery_label), length_prefixed(nonce), length_prefixed(address)}));
}

}  // namespace plexus::proto
