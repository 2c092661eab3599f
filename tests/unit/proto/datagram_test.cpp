#include "plexus/proto/datagram.hpp"

#include <gtest/gtest.h>

namespace plexus::proto {
namespace {

Bytes make_datagram(DatagramHeader header, const Bytes& fragment, const Bytes& tag = {}) {
    Bytes out;
    append_datagram_header(out, header);
    out.insert(out.end(), fragment.begin(), fragment.end());
    out.insert(out.end(), tag.begin(), tag.end());
    return out;
}

TEST(Datagram_test, RoundTripsAFragmentOfAMessage) {
    const Bytes fragment(100, 7);
    const auto datagram = make_datagram({9, 41, 250, 100, 2, false}, Bytes(50, 7));
    auto decoded = decode_datagram(datagram, 1000);
    ASSERT_TRUE(decoded) << decoded.error().message;
    EXPECT_EQ(decoded->header.stream, 9u);
    EXPECT_EQ(decoded->header.message, 41u);
    EXPECT_EQ(decoded->header.length, 250u);
    EXPECT_EQ(decoded->header.index, 2u);
    EXPECT_EQ(decoded->fragment.size(), 50u);  // the last fragment holds what is left
    EXPECT_TRUE(decoded->tag.empty());
    EXPECT_EQ(decoded->head.size() + decoded->fragment.size(), datagram.size());
}

TEST(Datagram_test, SeparatesHeaderFragmentAndTagOfASealedDatagram) {
    const Bytes tag(datagram_sealed_tag_size, 0xee);
    const auto datagram = make_datagram({1, 0, 3, 3, 0, true}, {1, 2, 3}, tag);
    auto decoded = decode_datagram(datagram, 1000);
    ASSERT_TRUE(decoded) << decoded.error().message;
    EXPECT_TRUE(decoded->header.sealed);
    EXPECT_EQ(Bytes(decoded->fragment.begin(), decoded->fragment.end()), (Bytes{1, 2, 3}));
    EXPECT_EQ(Bytes(decoded->tag.begin(), decoded->tag.end()), tag);
    EXPECT_EQ(decoded->head.size(), datagram.size() - 3 - datagram_sealed_tag_size);
}

TEST(Datagram_test, AnEmptyRecordIsOneEmptyFragment) {
    EXPECT_EQ(fragment_count(0, 1400), 1u);
    EXPECT_EQ(fragment_count(1400, 1400), 1u);
    EXPECT_EQ(fragment_count(1401, 1400), 2u);
    auto decoded = decode_datagram(make_datagram({1, 0, 0, 1400, 0, false}, {}), 10);
    ASSERT_TRUE(decoded) << decoded.error().message;
    EXPECT_TRUE(decoded->fragment.empty());
}

TEST(Datagram_test, RefusesEveryTruncation) {
    const auto datagram = make_datagram({300, 70000, 20, 10, 1, true}, Bytes(10, 1), Bytes(16, 2));
    ASSERT_TRUE(decode_datagram(datagram, 100));
    for (std::size_t n = 0; n < datagram.size(); ++n)
        EXPECT_FALSE(decode_datagram(ByteView(datagram).first(n), 100)) << "cut at " << n;
}

TEST(Datagram_test, RefusesWhatDoesNotAddUp) {
    auto reason = [](const Bytes& datagram, std::uint64_t max = 1000) {
        auto decoded = decode_datagram(datagram, max);
        return decoded ? std::string("accepted") : decoded.error().message;
    };
    EXPECT_EQ(reason(make_datagram({1, 0, 2000, 100, 0, false}, Bytes(100))),
              "message of 2000 bytes exceeds the limit 1000");
    EXPECT_EQ(reason(make_datagram({1, 0, 200, 100, 2, false}, Bytes(100))),
              "fragment 2 of a 2-fragment message");
    EXPECT_EQ(reason(make_datagram({1, 0, 200, 100, 0, false}, Bytes(99))),
              "fragment 0 holds 99 bytes, expected 100");
    EXPECT_EQ(reason(make_datagram({1, 0, 200, 0, 0, false}, {})), "fragment_size 0");
    EXPECT_EQ(reason(make_datagram({1, 0, 1u << 20, 1, 0, false}, Bytes(1)), 1u << 21),
              "message cut into 1048576 fragments, more than 65536");
    auto bad_magic = make_datagram({1, 0, 1, 1, 0, false}, {0});
    bad_magic[0] = 'X';
    EXPECT_EQ(reason(bad_magic), "not a Plexus datagram (bad magic)");
    auto bad_flags = make_datagram({1, 0, 1, 1, 0, false}, {0});
    bad_flags[5] = 0x80;
    EXPECT_EQ(reason(bad_flags), "unknown datagram flags 128");
    auto bad_version = make_datagram({1, 0, 1, 1, 0, false}, {0});
    bad_version[4] = 9;
    EXPECT_EQ(reason(bad_version), "datagram version 9, expected 2");
}

TEST(Datagram_test, AHugeFragmentSizeDoesNotOverflow) {
    auto decoded = decode_datagram(make_datagram({1, 0, 5, ~std::uint64_t{0}, 0, false}, Bytes(5)), 10);
    ASSERT_TRUE(decoded) << decoded.error().message;
    EXPECT_EQ(decoded->fragment.size(), 5u);
}

}  // namespace
}  // namespace plexus::proto
