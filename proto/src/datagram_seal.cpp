#include "plexus/proto/datagram_seal.hpp"

#include <openssl/evp.h>
#include <openssl/rand.h>

#include <stdexcept>

#include "plexus/proto/hex.hpp"

namespace plexus::proto {

namespace {

constexpr std::size_t nonce_size = 12;

std::array<std::uint8_t, nonce_size> nonce_of(std::uint64_t message, std::uint64_t index) {
    std::array<std::uint8_t, nonce_size> nonce{};
    for (int i = 0; i < 8; ++i)
        nonce[i] = static_cast<std::uint8_t>(message >> (56 - 8 * i));
    // max_datagram_fragments (2^16) keeps every index within these four bytes.
    for (int i = 0; i < 4; ++i)
        nonce[8 + i] = static_cast<std::uint8_t>(index >> (24 - 8 * i));
    return nonce;
}

}  // namespace

struct DatagramSeal::Cipher {
    EVP_CIPHER_CTX* context = nullptr;
    explicit Cipher(const DatagramKey& key, bool encrypting) : context(::EVP_CIPHER_CTX_new()) {
        // The key is set once; every datagram sets only its nonce.
        const bool made =
            context != nullptr &&
            (encrypting
                 ? ::EVP_EncryptInit_ex(context, ::EVP_aes_128_gcm(), nullptr, key.data(), nullptr) == 1
                 : ::EVP_DecryptInit_ex(context, ::EVP_aes_128_gcm(), nullptr, key.data(), nullptr) == 1);
        if (!made) {
            ::EVP_CIPHER_CTX_free(context);
            throw std::runtime_error("OpenSSL could not make an AES-128-GCM context");
        }
    }
    ~Cipher() { ::EVP_CIPHER_CTX_free(context); }
};

DatagramKey random_datagram_key() {
    DatagramKey key{};
    if (::RAND_bytes(key.data(), static_cast<int>(key.size())) != 1)
        throw std::runtime_error("no random numbers from the kernel (RAND_bytes failed)");
    return key;
}

std::string key_text(const DatagramKey& key) {
    return hex_text(key);
}

Result<DatagramKey> parse_key_text(const std::string& text) {
    DatagramKey key{};
    if (text.size() != 2 * key.size())
        return Error{"a datagram key is " + std::to_string(2 * key.size()) + " hexadecimal digits, not " +
                     std::to_string(text.size()) + " characters"};
    for (std::size_t i = 0; i < key.size(); ++i) {
        const int high = hex_digit_value(text[2 * i]);
        const int low = hex_digit_value(text[2 * i + 1]);
        if (high < 0 || low < 0)
            return Error{"a datagram key holds a character that is not a hexadecimal digit"};
        key[i] = static_cast<std::uint8_t>(high << 4 | low);
    }
    return key;
}

DatagramSeal::DatagramSeal(const DatagramKey& key)
    : key_(key),
      encrypt_(std::make_unique<Cipher>(key, true)),
      decrypt_(std::make_unique<Cipher>(key, false)) {}

DatagramSeal::~DatagramSeal() = default;

void DatagramSeal::seal(ByteView head, std::uint64_t message, std::uint64_t index, ByteView plain,
                        std::uint8_t* out, std::uint8_t* tag) {
    EVP_CIPHER_CTX* context = encrypt_->context;
    const auto nonce = nonce_of(message, index);
    int written = 0;
    // Each call below fails only on arguments this code controls (sizes under 2^31, a context
    // already keyed): a failure is a bug, not a peer's doing.
    if (::EVP_EncryptInit_ex(context, nullptr, nullptr, nullptr, nonce.data()) != 1 ||
        ::EVP_EncryptUpdate(context, nullptr, &written, head.data(), static_cast<int>(head.size())) != 1 ||
        (!plain.empty() &&
         ::EVP_EncryptUpdate(context, out, &written, plain.data(), static_cast<int>(plain.size())) != 1) ||
        ::EVP_EncryptFinal_ex(context, out + plain.size(), &written) != 1 ||
        ::EVP_CIPHER_CTX_ctrl(context, EVP_CTRL_GCM_GET_TAG, static_cast<int>(datagram_sealed_tag_size),
                              tag) != 1)
        throw std::runtime_error("OpenSSL failed to seal a datagram");
}

bool DatagramSeal::open(ByteView head, std::uint64_t message, std::uint64_t index, ByteView sealed,
                        ByteView tag, std::uint8_t* out) {
    if (tag.size() != datagram_sealed_tag_size)
        return false;
    EVP_CIPHER_CTX* context = decrypt_->context;
    const auto nonce = nonce_of(message, index);
    int written = 0;
    if (::EVP_DecryptInit_ex(context, nullptr, nullptr, nullptr, nonce.data()) != 1 ||
        ::EVP_DecryptUpdate(context, nullptr, &written, head.data(), static_cast<int>(head.size())) != 1 ||
        (!sealed.empty() &&
         ::EVP_DecryptUpdate(context, out, &written, sealed.data(), static_cast<int>(sealed.size())) != 1) ||
        ::EVP_CIPHER_CTX_ctrl(context, EVP_CTRL_GCM_SET_TAG, static_cast<int>(datagram_sealed_tag_size),
                              const_cast<std::uint8_t*>(tag.data())) != 1)
        return false;
    // The tag is checked here, in constant time, by OpenSSL.
    return ::EVP_DecryptFinal_ex(context, out + sealed.size(), &written) == 1;
}

}  // namespace plexus::proto
