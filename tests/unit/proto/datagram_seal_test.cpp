#include "plexus/proto/datagram_seal.hpp"

#include <gtest/gtest.h>

namespace plexus::proto {
namespace {

struct Sealed {
    Bytes head;
    Bytes body;
    Bytes tag = Bytes(datagram_sealed_tag_size);
};

Sealed seal_with(DatagramSeal& seal, std::uint64_t message, std::uint64_t index, const Bytes& plain) {
    Sealed out;
    append_datagram_header(out.head, {7, message, 3000, 1400, index, true});
    out.body.resize(plain.size());
    seal.seal(out.head, message, index, plain, out.body.data(), out.tag.data());
    return out;
}

TEST(DatagramSeal_test, OpensWhatItSealedAndHidesIt) {
    DatagramSeal seal(random_datagram_key());
    const Bytes plain(1400, 'x');
    const auto sealed = seal_with(seal, 3, 1, plain);
    EXPECT_NE(sealed.body, plain);
    Bytes opened(plain.size());
    ASSERT_TRUE(seal.open(sealed.head, 3, 1, sealed.body, sealed.tag, opened.data()));
    EXPECT_EQ(opened, plain);
    // An empty fragment (an empty message) is sealed too: its tag still authenticates the header.
    const auto empty = seal_with(seal, 4, 0, {});
    EXPECT_TRUE(seal.open(empty.head, 4, 0, {}, empty.tag, opened.data()));
}

TEST(DatagramSeal_test, RefusesEveryChangeAndEveryOtherKeyOrPlace) {
    DatagramSeal seal(random_datagram_key());
    const Bytes plain(100, 'y');
    const auto sealed = seal_with(seal, 9, 0, plain);
    Bytes opened(plain.size());
    for (std::size_t i = 0; i < sealed.body.size(); i += 7) {
        auto changed = sealed.body;
        changed[i] ^= 0x01;
        EXPECT_FALSE(seal.open(sealed.head, 9, 0, changed, sealed.tag, opened.data())) << i;
    }
    for (std::size_t i = 0; i < sealed.head.size(); ++i) {
        auto changed = sealed.head;
        changed[i] ^= 0x01;
        EXPECT_FALSE(seal.open(changed, 9, 0, sealed.body, sealed.tag, opened.data())) << i;
    }
    auto bad_tag = sealed.tag;
    bad_tag[15] ^= 0x80;
    EXPECT_FALSE(seal.open(sealed.head, 9, 0, sealed.body, bad_tag, opened.data()));
    EXPECT_FALSE(seal.open(sealed.head, 9, 0, sealed.body, ByteView(sealed.tag).first(15), opened.data()));
    // Another place in the stream (a datagram moved to another message or fragment).
    EXPECT_FALSE(seal.open(sealed.head, 10, 0, sealed.body, sealed.tag, opened.data()));
    EXPECT_FALSE(seal.open(sealed.head, 9, 1, sealed.body, sealed.tag, opened.data()));
    // Another key: a stream of before a restart.
    DatagramSeal other(random_datagram_key());
    EXPECT_FALSE(other.open(sealed.head, 9, 0, sealed.body, sealed.tag, opened.data()));
    // A refusal leaves the context fit for the next datagram.
    EXPECT_TRUE(seal.open(sealed.head, 9, 0, sealed.body, sealed.tag, opened.data()));
    EXPECT_EQ(opened, plain);
}

TEST(DatagramSeal_test, KeysTravelAsThirtyTwoHexDigits) {
    const auto key = random_datagram_key();
    EXPECT_NE(key, random_datagram_key());
    const auto text = key_text(key);
    EXPECT_EQ(text.size(), 32u);
    auto parsed = parse_key_text(text);
    ASSERT_TRUE(parsed) << parsed.error().message;
    EXPECT_EQ(*parsed, key);
    EXPECT_FALSE(parse_key_text(text.substr(1)));
    EXPECT_FALSE(parse_key_text(std::string(31, '0') + "g"));
    EXPECT_EQ(*parse_key_text(std::string(32, 'F')), DatagramKey{[] {
        DatagramKey all{};
        all.fill(0xff);
        return all;
    }()});
}

}  // namespace
}  // namespace plexus::proto
