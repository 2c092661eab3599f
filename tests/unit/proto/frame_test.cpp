#include "plexus/proto/frame.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <limits>
#include <new>
#include <random>
#include <string>
#include <vector>

#include "plexus/proto/call.hpp"
#include "plexus/proto/control.hpp"
#include "plexus/proto/hello.hpp"
#include "plexus/proto/message.hpp"
#include "plexus/proto/rings.hpp"
#include "plexus/proto/shm.hpp"
#include "plexus/proto/varint.hpp"

// Replaces the global allocator of this test program to record the largest allocation made while
// `tracking` is set: that is how the tests prove that a lying length never turns into an allocation.
namespace {
std::atomic<bool> tracking{false};
std::atomic<std::size_t> largest_allocation{0};
}  // namespace

void* operator new(std::size_t size) {
    if (tracking.load(std::memory_order_relaxed)) {
        std::size_t seen = largest_allocation.load(std::memory_order_relaxed);
        while (size > seen && !largest_allocation.compare_exchange_weak(seen, size)) {
        }
    }
    if (void* p = std::malloc(size == 0 ? 1 : size)) {
        return p;
    }
    throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t /*size*/) noexcept {
    std::free(p);
}

namespace plexus::proto {
namespace {

struct SeenFrame {
    FrameType type;
    Bytes fields;
    bool operator==(const SeenFrame&) const = default;
};

Bytes header_only(std::uint64_t length, FrameType type = FrameType::data) {
    Bytes out;
    append_varint(out, length);
    out.push_back(static_cast<std::uint8_t>(type));
    return out;
}

// Frames of every type, one with a two-byte length, one with no fields at all.
std::vector<Bytes> sample_frames() {
    std::vector<Bytes> frames;
    frames.push_back(encode_hello({protocol_version, "daemon", "node-a"}));
    frames.push_back(encode_request({7, {{"op", "connect"}, {"src", "/a"}, {"dst", "/b"}}}));
    Bytes record;
    append_record(record, "/camera/out", 42, 1'700'000'000'000'000'000ull, Bytes(300, 0xab));
    Bytes data;
    append_data_frame(data, 3, record);
    frames.push_back(data);
    frames.push_back(encode_reply({7, ReplyCode::refused, {{"error", "no such port"}}}));
    Bytes empty;
    append_frame(empty, FrameType::data, {});
    frames.push_back(empty);
    frames.push_back(make_error_frame("bye"));
    return frames;
}

Bytes concatenate(const std::vector<Bytes>& frames) {
    Bytes all;
    for (const auto& frame : frames) {
        all.insert(all.end(), frame.begin(), frame.end());
    }
    return all;
}

std::vector<SeenFrame> expected_frames() {
    std::vector<SeenFrame> seen;
    const FrameDecoder decoder;
    for (const auto& frame : sample_frames()) {
        const FrameDecode decoded = decoder.decode(frame);
        EXPECT_EQ(decoded.status, DecodeStatus::frame);
        seen.push_back({decoded.type, Bytes(decoded.fields.begin(), decoded.fields.end())});
    }
    return seen;
}

// Reads `chunks` as a socket would deliver them: append each chunk to a buffer, take every whole
// frame off its front, keep the rest for the next chunk.
std::vector<SeenFrame> feed(const std::vector<ByteView>& chunks) {
    const FrameDecoder decoder;
    Bytes buffer;
    std::vector<SeenFrame> seen;
    for (const ByteView chunk : chunks) {
        buffer.insert(buffer.end(), chunk.begin(), chunk.end());
        for (;;) {
            const FrameDecode decoded = decoder.decode(buffer);
            if (decoded.status == DecodeStatus::need_more) {
                EXPECT_GT(decoded.needed, buffer.size());
                break;
            }
            if (decoded.status == DecodeStatus::bad) {
                ADD_FAILURE() << decoded.error;
                return seen;
            }
            seen.push_back({decoded.type, Bytes(decoded.fields.begin(), decoded.fields.end())});
            buffer.erase(buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(decoded.used));
        }
    }
    EXPECT_TRUE(buffer.empty());
    return seen;
}

TEST(FrameDecoder_test, DecodesOneFrame) {
    Bytes fields{1, 2, 3};
    Bytes frame;
    append_frame(frame, FrameType::request, fields);
    EXPECT_EQ(frame, (Bytes{4, 2, 1, 2, 3}));
    frame.push_back(0x99);  // the start of the next frame is left alone

    const FrameDecode decoded = FrameDecoder().decode(frame);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    EXPECT_EQ(decoded.type, FrameType::request);
    EXPECT_EQ(Bytes(decoded.fields.begin(), decoded.fields.end()), fields);
    EXPECT_EQ(decoded.used, 5u);
    EXPECT_EQ(decoded.fields.data(), frame.data() + 2);  // a view into the input, not a copy
}

TEST(FrameDecoder_test, DecodesFrameSplitAtEveryByte) {
    const Bytes all = concatenate(sample_frames());
    const std::vector<SeenFrame> expected = expected_frames();
    const ByteView view(all);
    for (std::size_t i = 0; i <= all.size(); ++i) {
        ASSERT_EQ(feed({view.first(i), view.subspan(i)}), expected) << "split at " << i;
    }
}

TEST(FrameDecoder_test, DecodesFrameSplitAtEveryPairOfBytes) {
    const Bytes all = concatenate(sample_frames());
    const std::vector<SeenFrame> expected = expected_frames();
    const ByteView view(all);
    for (std::size_t i = 0; i <= all.size(); ++i) {
        for (std::size_t j = i; j <= all.size(); ++j) {
            ASSERT_EQ(feed({view.first(i), view.subspan(i, j - i), view.subspan(j)}), expected)
                << "split at " << i << " and " << j;
        }
    }
}

TEST(FrameDecoder_test, DecodesFrameFedOneByteAtATime) {
    const Bytes all = concatenate(sample_frames());
    std::vector<ByteView> chunks;
    for (std::size_t i = 0; i < all.size(); ++i) {
        chunks.push_back(ByteView(all).subspan(i, 1));
    }
    EXPECT_EQ(feed(chunks), expected_frames());
}

TEST(FrameDecoder_test, NeedsMoreForEveryTruncation) {
    const FrameDecoder decoder;
    for (const Bytes& frame : sample_frames()) {
        for (std::size_t n = 0; n < frame.size(); ++n) {
            const FrameDecode decoded = decoder.decode(ByteView(frame).first(n));
            ASSERT_EQ(decoded.status, DecodeStatus::need_more) << "cut at " << n << ": " << decoded.error;
            EXPECT_GT(decoded.needed, n);
            EXPECT_LE(decoded.needed, frame.size());
        }
        EXPECT_EQ(decoder.decode(frame).status, DecodeStatus::frame);
    }
}

TEST(FrameDecoder_test, NeededIsWholeFrameOnceLengthIsKnown) {
    const Bytes frame = sample_frames()[2];  // the data frame with a two-byte length
    const FrameDecode decoded = FrameDecoder().decode(ByteView(frame).first(3));
    ASSERT_EQ(decoded.status, DecodeStatus::need_more);
    EXPECT_EQ(decoded.needed, frame.size());
}

TEST(FrameDecoder_test, RefusesOversizedDeclaredLengthsWithoutAllocating) {
    // The tracker itself works: a big allocation while tracking is seen.
    largest_allocation = 0;
    tracking = true;
    const Bytes probe(4096);
    tracking = false;
    ASSERT_GE(largest_allocation.load(), probe.size());

    const FrameDecoder decoder;
    struct Case {
        std::uint64_t length;
        std::string text;
    };
    const Case cases[] = {
        {1ull << 31, "2147483648"},
        {1ull << 32, "4294967296"},
        {std::numeric_limits<std::uint64_t>::max(), "18446744073709551615"},
        {default_max_frame + 1, "67108865"},
    };
    for (const auto& c : cases) {
        const Bytes input = header_only(c.length);
        largest_allocation = 0;
        tracking = true;
        const FrameDecode decoded = decoder.decode(input);
        tracking = false;
        ASSERT_EQ(decoded.status, DecodeStatus::bad) << c.text;
        EXPECT_EQ(decoded.error, "frame length " + c.text + " exceeds limit 67108864");
        EXPECT_LT(largest_allocation.load(), 1024u) << c.text;
        // The length alone is enough to refuse: no type byte needed.
        Bytes bare;
        append_varint(bare, c.length);
        EXPECT_EQ(decoder.decode(bare).status, DecodeStatus::bad) << c.text;
    }
}

TEST(FrameDecoder_test, AcceptsLengthOfExactlyTheLimit) {
    const Bytes header = header_only(default_max_frame);
    const FrameDecode waiting = FrameDecoder().decode(header);
    ASSERT_EQ(waiting.status, DecodeStatus::need_more);
    EXPECT_EQ(waiting.needed, varint_size(default_max_frame) + default_max_frame);

    const FrameDecoder small(100);
    Bytes frame;
    append_frame(frame, FrameType::data, Bytes(99, 0x11));
    const FrameDecode decoded = small.decode(frame);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    EXPECT_EQ(decoded.fields.size(), 99u);

    Bytes too_big;
    append_frame(too_big, FrameType::data, Bytes(100, 0x11));
    const FrameDecode refused = small.decode(too_big);
    ASSERT_EQ(refused.status, DecodeStatus::bad);
    EXPECT_EQ(refused.error, "frame length 101 exceeds limit 100");
}

TEST(FrameDecoder_test, RefusesEmptyFrame) {
    const FrameDecode decoded = FrameDecoder().decode(Bytes{0x00, 0x01});
    ASSERT_EQ(decoded.status, DecodeStatus::bad);
    EXPECT_EQ(decoded.error, "frame length 0: a frame holds at least its type byte");
}

TEST(FrameDecoder_test, RefusesUnknownTypeAsSoonAsItArrives) {
    const FrameDecode decoded = FrameDecoder().decode(Bytes{0x10, 0x10});  // body not yet here
    ASSERT_EQ(decoded.status, DecodeStatus::bad);
    EXPECT_EQ(decoded.error, "unknown frame type 16");
    EXPECT_EQ(FrameDecoder().decode(Bytes{0x01, 0x00}).status, DecodeStatus::bad);
}

TEST(FrameDecoder_test, RefusesOverlongLengthVarint) {
    Bytes input(10, 0x80);
    input.push_back(0x00);
    const FrameDecode decoded = FrameDecoder().decode(input);
    ASSERT_EQ(decoded.status, DecodeStatus::bad);
    EXPECT_EQ(decoded.error, "bad frame length: varint longer than 10 bytes or over 64 bits");
}

// Hands the fields to the decoder for their type, as a session would; any outcome but a crash is fine.
void decode_fields(const FrameDecode& frame) {
    switch (frame.type) {
        case FrameType::hello:
            (void)decode_hello(frame.fields);
            break;
        case FrameType::request:
            (void)decode_request(frame.fields);
            break;
        case FrameType::reply:
            (void)decode_reply(frame.fields);
            break;
        case FrameType::data:
            if (const auto data = decode_data(frame.fields)) {
                (void)decode_record(data->record);
            }
            break;
        case FrameType::error:
            (void)decode_error(frame.fields);
            break;
        case FrameType::data_batch:
            if (const auto batch = decode_batch(frame.fields)) {
                BatchRecords records(batch->records, batch->count);
                while (const auto record = records.next())
                    (void)decode_record(*record);
            }
            break;
        case FrameType::data_shm:
            (void)decode_shm_data(frame.fields);
            break;
        case FrameType::shm_region:
            (void)decode_shm_region(frame.fields);
            break;
        case FrameType::shm_free:
            (void)decode_shm_free(frame.fields);
            break;
        case FrameType::call:
            (void)decode_call(frame.fields);
            break;
        case FrameType::answer:
            (void)decode_answer(frame.fields);
            break;
        case FrameType::rings:
            (void)decode_rings_request(frame.fields);
            (void)decode_rings_answer(frame.fields);
            break;
        case FrameType::shm_release:      // a count, read where it is used (daemon/net/session.cpp)
        case FrameType::shm_region_gone:  // a region number, read by libplexus
        case FrameType::auth:             // 32 raw bytes, compared, never decoded
            break;
    }
}

TEST(FrameDecoder_test, SurvivesRandomBytes) {
    std::mt19937_64 random(20240601);
    const FrameDecoder decoders[] = {FrameDecoder(), FrameDecoder(64)};
    for (int iteration = 0; iteration < 200'000; ++iteration) {
        Bytes input(random() % 48);
        for (auto& byte : input) {
            byte = static_cast<std::uint8_t>(random());
        }
        // Half the time, a plausible header so that the type and body checks are reached too.
        if (iteration % 2 == 0 && !input.empty()) {
            input[0] = static_cast<std::uint8_t>(random() % 48);
            if (input.size() > 1) {
                input[1] = static_cast<std::uint8_t>(1 + random() % 5);
            }
        }
        for (const auto& decoder : decoders) {
            const FrameDecode decoded = decoder.decode(input);
            switch (decoded.status) {
                case DecodeStatus::frame:
                    ASSERT_LE(decoded.used, input.size());
                    ASSERT_GE(decoded.fields.data(), input.data());
                    ASSERT_LE(decoded.fields.data() + decoded.fields.size(), input.data() + decoded.used);
                    decode_fields(decoded);
                    break;
                case DecodeStatus::need_more:
                    ASSERT_GT(decoded.needed, input.size());
                    break;
                case DecodeStatus::bad:
                    ASSERT_FALSE(decoded.error.empty());
                    break;
                default:
                    FAIL() << "status out of range";
            }
        }
    }
}

TEST(ErrorFrame_test, RoundTripsReason) {
    const Bytes frame = make_error_frame("frame length 4294967296 exceeds limit 67108864");
    const FrameDecode decoded = FrameDecoder().decode(frame);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    EXPECT_EQ(decoded.type, FrameType::error);
    const auto reason = decode_error(decoded.fields);
    ASSERT_TRUE(reason) << reason.error().message;
    EXPECT_EQ(*reason, "frame length 4294967296 exceeds limit 67108864");
}

TEST(ErrorFrame_test, CutsLongReasonAtCharacterBoundary) {
    // 4095 ASCII bytes then a two-byte character that would straddle the limit.
    const std::string reason = std::string(max_error_reason - 1, 'x') + "\xc3\xa9" + "tail";
    const Bytes frame = make_error_frame(reason);
    const FrameDecode decoded = FrameDecoder().decode(frame);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    const auto text = decode_error(decoded.fields);
    ASSERT_TRUE(text);
    EXPECT_EQ(*text, std::string(max_error_reason - 1, 'x'));
}

TEST(ErrorFrame_test, RefusesEveryTruncation) {
    const Bytes frame = make_error_frame("bye");
    const FrameDecode decoded = FrameDecoder().decode(frame);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    for (std::size_t n = 0; n < decoded.fields.size(); ++n) {
        EXPECT_FALSE(decode_error(decoded.fields.first(n))) << n;
    }
}

TEST(FrameTypeName_test, NamesKnownAndUnknownTypes) {
    EXPECT_EQ(frame_type_name(1), "hello");
    EXPECT_EQ(frame_type_name(2), "request");
    EXPECT_EQ(frame_type_name(3), "reply");
    EXPECT_EQ(frame_type_name(4), "data");
    EXPECT_EQ(frame_type_name(5), "error");
    EXPECT_EQ(frame_type_name(6), "data_batch");
    EXPECT_EQ(frame_type_name(13), "call");
    EXPECT_EQ(frame_type_name(14), "answer");
    EXPECT_EQ(frame_type_name(15), "rings");
    EXPECT_EQ(frame_type_name(16), "unknown(16)");
    EXPECT_EQ(frame_type_name(0), "unknown(0)");
}

}  // namespace
}  // namespace plexus::proto
