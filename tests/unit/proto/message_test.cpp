#include "plexus/proto/message.hpp"

#include <gtest/gtest.h>

#include <limits>

#include "plexus/proto/fields.hpp"
#include "plexus/proto/frame.hpp"
#include "plexus/proto/varint.hpp"

namespace plexus::proto {
namespace {

constexpr std::uint64_t max_u64 = std::numeric_limits<std::uint64_t>::max();

Bytes make_record(std::string_view source, std::uint64_t seq, std::uint64_t time_ns, const Bytes& payload) {
    Bytes record;
    append_record(record, source, seq, time_ns, payload);
    EXPECT_EQ(record.size(), record_size(source, seq, time_ns, payload.size()));
    return record;
}

TEST(Record_test, RoundTrips) {
    const Bytes payload{0xa1, 0x61, 'x', 0x01};
    const Bytes record = make_record("/camera/out", 42, 1'700'000'000'123'456'789ull, payload);
    const auto view = decode_record(record);
    ASSERT_TRUE(view) << view.error().message;
    EXPECT_EQ(view->source, "/camera/out");
    EXPECT_EQ(view->seq, 42u);
    EXPECT_EQ(view->time_ns, 1'700'000'000'123'456'789ull);
    EXPECT_EQ(Bytes(view->payload.begin(), view->payload.end()), payload);
}

TEST(Record_test, RoundTripsExtremes) {
    const std::string source(max_port_name, 'a');
    const Bytes record = make_record(source, max_u64, max_u64, {});
    const auto view = decode_record(record);
    ASSERT_TRUE(view) << view.error().message;
    EXPECT_EQ(view->source, source);
    EXPECT_EQ(view->seq, max_u64);
    EXPECT_EQ(view->time_ns, max_u64);
    EXPECT_TRUE(view->payload.empty());
}

TEST(Record_test, HasDocumentedLayout) {
    EXPECT_EQ(make_record("/a", 1, 300, {9}), (Bytes{0x02, '/', 'a', 0x01, 0xac, 0x02, 0x09}));
}

TEST(Record_test, RefusesEveryTruncationOfEnvelope) {
    const Bytes payload{1, 2, 3};
    const Bytes record = make_record("/camera/out", 1000, 1ull << 40, payload);
    const std::size_t envelope = record.size() - payload.size();
    for (std::size_t n = 0; n < record.size(); ++n) {
        const auto view = decode_record(ByteView(record).first(n));
        if (n < envelope) {
            EXPECT_FALSE(view) << "cut at " << n;
        } else {
            // The payload is whatever follows the envelope: a cut there is a shorter payload.
            ASSERT_TRUE(view) << "cut at " << n;
            EXPECT_EQ(view->payload.size(), n - envelope);
        }
    }
}

TEST(Record_test, RefusesSourceLongerThanPortNameLimit) {
    const Bytes record = make_record(std::string(max_port_name + 1, 'a'), 1, 1, {});
    const auto view = decode_record(record);
    ASSERT_FALSE(view);
    EXPECT_EQ(view.error().message, "bad record: source longer than 255 bytes (256)");
}

TEST(Record_test, TheLeanReaderTakesAndRefusesWhatDecodeRecordDoes) {
    const std::string longest(max_port_name, 'a');
    const Bytes records[] = {make_record("/camera/out", 1000, 1ull << 40, {1, 2, 3}),
                             make_record(longest, max_u64, max_u64, {}),
                             make_record(longest + "a", 1, 1, {})};
    for (const auto& record : records) {
        for (std::size_t n = 0; n <= record.size(); ++n) {
            const ByteView cut = ByteView(record).first(n);
            const auto full = decode_record(cut);
            const auto lean = read_record(cut);
            ASSERT_EQ(full.ok(), lean.has_value()) << "cut at " << n << " of " << record.size();
            if (!lean)
                continue;
            EXPECT_EQ(lean->source, full->source);
            EXPECT_EQ(lean->seq, full->seq);
            EXPECT_EQ(lean->time_ns, full->time_ns);
            EXPECT_EQ(lean->payload.data(), full->payload.data());
            EXPECT_EQ(lean->payload.size(), full->payload.size());
        }
    }
}

TEST(Record_test, NamesTruncatedField) {
    Bytes record;
    append_string(record, "/a");
    append_varint(record, 5);
    const auto view = decode_record(record);
    ASSERT_FALSE(view);
    EXPECT_EQ(view.error().message, "bad record: truncated time");
}

TEST(DataFrame_test, RoundTrips) {
    const Bytes record = make_record("/a", 1, 2, Bytes(200, 0x5a));
    Bytes frame;
    append_data_frame(frame, 300, record);
    const FrameDecode decoded = FrameDecoder().decode(frame);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    EXPECT_EQ(decoded.type, FrameType::data);
    EXPECT_EQ(decoded.used, frame.size());
    const auto data = decode_data(decoded.fields);
    ASSERT_TRUE(data) << data.error().message;
    EXPECT_EQ(data->handle, 300u);
    EXPECT_EQ(Bytes(data->record.begin(), data->record.end()), record);
    const auto view = decode_record(data->record);
    ASSERT_TRUE(view);
    EXPECT_EQ(view->payload.size(), 200u);
}

TEST(DataFrame_test, PrefixPlusRecordEqualsWholeFrame) {
    const Bytes record = make_record("/a/b", 9, 10, Bytes(130, 1));
    Bytes whole;
    append_data_frame(whole, max_u64, record);
    Bytes gathered;
    append_data_frame_prefix(gathered, max_u64, record.size());
    gathered.insert(gathered.end(), record.begin(), record.end());
    EXPECT_EQ(gathered, whole);
}

TEST(DataFrame_test, RefusesEveryTruncationOfHandle) {
    const Bytes record = make_record("/a", 1, 2, {7});
    Bytes frame;
    append_data_frame(frame, 1ull << 50, record);
    const FrameDecode decoded = FrameDecoder().decode(frame);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    const std::size_t handle_size = varint_size(1ull << 50);
    for (std::size_t n = 0; n < decoded.fields.size(); ++n) {
        const auto data = decode_data(decoded.fields.first(n));
        if (n < handle_size) {
            ASSERT_FALSE(data) << n;
            EXPECT_EQ(data.error().message, "bad data frame: truncated handle");
        } else {
            ASSERT_TRUE(data) << n;
            EXPECT_EQ(data->record.size(), n - handle_size);
        }
    }
}

/// A whole batch frame of `count` records from /cam with payloads of `payload_size` bytes.
Bytes batch_frame(std::uint64_t handle, std::uint64_t count, std::size_t payload_size) {
    Bytes records;
    for (std::uint64_t i = 1; i <= count; ++i)
        append_batch_record(records, "/cam", i, 1000 + i, Bytes(payload_size, static_cast<std::uint8_t>(i)));
    Bytes frame;
    append_batch_frame_prefix(frame, handle, count, records.size());
    frame.insert(frame.end(), records.begin(), records.end());
    return frame;
}

TEST(BatchFrame_test, RoundTripsEveryRecordInOrder) {
    const Bytes frame = batch_frame(42, 3, 5);
    const auto decoded = FrameDecoder().decode(frame);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    EXPECT_EQ(decoded.type, FrameType::data_batch);
    EXPECT_EQ(decoded.used, frame.size());
    const auto batch = decode_batch(decoded.fields);
    ASSERT_TRUE(batch) << batch.error().message;
    EXPECT_EQ(batch->handle, 42u);
    EXPECT_EQ(batch->count, 3u);
    BatchRecords records(batch->records, batch->count);
    for (std::uint64_t i = 1; i <= 3; ++i) {
        const auto record = records.next();
        ASSERT_TRUE(record) << records.error();
        const auto view = decode_record(*record);
        ASSERT_TRUE(view);
        EXPECT_EQ(view->source, "/cam");
        EXPECT_EQ(view->seq, i);
        EXPECT_EQ(view->time_ns, 1000 + i);
        EXPECT_EQ(Bytes(view->payload.begin(), view->payload.end()), Bytes(5, static_cast<std::uint8_t>(i)));
    }
    EXPECT_FALSE(records.next());
    EXPECT_EQ(records.error(), "");
}

TEST(BatchFrame_test, RefusesCountZeroAndCountsOverTheLimit) {
    Bytes fields;
    append_varint(fields, 1);
    append_varint(fields, 0);
    EXPECT_EQ(decode_batch(fields).error().message, "bad batch frame: count 0 outside 1..1048576");
    fields.clear();
    append_varint(fields, 1);
    append_varint(fields, std::numeric_limits<std::uint64_t>::max());
    EXPECT_FALSE(decode_batch(fields));
}

TEST(BatchFrame_test, EveryTruncationOfTheRecordsIsAnErrorNotACrash) {
    const Bytes frame = batch_frame(7, 4, 3);
    const auto whole = FrameDecoder().decode(frame);
    ASSERT_EQ(whole.status, DecodeStatus::frame);
    const auto batch = decode_batch(whole.fields);
    ASSERT_TRUE(batch);
    for (std::size_t cut = 0; cut < batch->records.size(); ++cut) {
        BatchRecords records(batch->records.first(cut), batch->count);
        std::size_t seen = 0;
        while (records.next())
            ++seen;
        EXPECT_LT(seen, 4u) << "cut at " << cut;
        EXPECT_NE(records.error(), "") << "cut at " << cut;
    }
}

TEST(BatchFrame_test, RefusesARecordLengthPastTheEndAndBytesAfterTheLastRecord) {
    Bytes lying;
    append_varint(lying, std::uint64_t{1} << 32);  // a record "of 4 GiB" in a 10-byte batch
    lying.resize(10, 0);
    BatchRecords records(lying, 1);
    EXPECT_FALSE(records.next());
    EXPECT_NE(records.error().find("record"), std::string::npos) << records.error();

    Bytes extra;
    append_batch_record(extra, "/a", 1, 1, {});
    extra.push_back(0x00);
    BatchRecords trailing(extra, 1);
    EXPECT_TRUE(trailing.next());
    EXPECT_FALSE(trailing.next());
    EXPECT_EQ(trailing.error(), "bad batch frame: 1 bytes after the last record");
}

TEST(BatchFrame_test, TheFastSourceCheckPassesGoodRecordsAndNothingElse) {
    Bytes source_field;
    append_string(source_field, "/cam");
    Bytes good;
    append_batch_record(good, "/cam", 1, 10, Bytes{1, 2});
    append_batch_record(good, "/cam", 2, 20, {});
    EXPECT_TRUE(batch_records_from(good, 2, source_field));
    EXPECT_FALSE(batch_records_from(good, 3, source_field)) << "fewer records than the count";
    EXPECT_FALSE(batch_records_from(good, 1, source_field)) << "bytes after the last record";
    for (std::size_t cut = 0; cut < good.size(); ++cut)
        EXPECT_FALSE(batch_records_from(ByteView(good).first(cut), 2, source_field)) << "cut at " << cut;

    Bytes foreign;
    append_batch_record(foreign, "/cam", 1, 10, {});
    append_batch_record(foreign, "/cax", 2, 20, {});
    EXPECT_FALSE(batch_records_from(foreign, 2, source_field));

    Bytes record;
    append_record(record, "/cam", 1, 10, Bytes{9});
    EXPECT_TRUE(record_from(record, source_field));
    Bytes longer_name;
    append_record(longer_name, "/camera", 1, 10, {});
    EXPECT_FALSE(record_from(longer_name, source_field));
    // A padded seq varint is a valid varint for both checks.
    Bytes padded = source_field;
    padded.insert(padded.end(), {0x81, 0x80, 0x00, 0x05});
    EXPECT_TRUE(decode_record(padded).ok());
    EXPECT_TRUE(record_from(padded, source_field)) << "padding inside ten bytes is a valid varint";
    Bytes broken = source_field;
    broken.insert(broken.end(), {0x81});  // seq cut short, no time
    EXPECT_FALSE(record_from(broken, source_field));
}

}  // namespace
}  // namespace plexus::proto
