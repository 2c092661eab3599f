#include "plexus/proto/call.hpp"

#include <gtest/gtest.h>

#include "plexus/proto/message.hpp"

namespace plexus::proto {
namespace {

ByteView fields_of(const Bytes& frame) {
    const auto decoded = FrameDecoder().decode(frame);
    EXPECT_EQ(decoded.status, DecodeStatus::frame);
    return decoded.fields;
}

TEST(CallFrame_test, RoundTripsEveryField) {
    Bytes record;
    append_record(record, "/caller", 7, 123456789, Bytes{0x63, 'a', 'b', 'c'});
    Bytes frame;
    append_call_frame(frame, 3, 1ull << 40, 2500, record);
    const auto decoded = FrameDecoder().decode(frame);
    ASSERT_EQ(decoded.status, DecodeStatus::frame);
    EXPECT_EQ(decoded.type, FrameType::call);
    const auto call = decode_call(decoded.fields);
    ASSERT_TRUE(call.ok()) << call.error().message;
    EXPECT_EQ(call->handle, 3u);
    EXPECT_EQ(call->id, 1ull << 40);
    EXPECT_EQ(call->timeout_ms, 2500u);
    EXPECT_EQ(Bytes(call->record.begin(), call->record.end()), record);
}

TEST(CallFrame_test, PrefixThenRecordIsTheWholeFrame) {
    Bytes record;
    append_record(record, "/x", 1, 2, Bytes{0xf6});
    Bytes whole;
    append_call_frame(whole, 1, 2, 3, record);
    Bytes pieces;
    append_call_frame_prefix(pieces, 1, 2, 3, record.size());
    pieces.insert(pieces.end(), record.begin(), record.end());
    EXPECT_EQ(pieces, whole);
}

TEST(CallFrame_test, RefusesATimeoutPastTheLimit) {
    Bytes frame;
    append_call_frame(frame, 1, 1, max_call_timeout_ms + 1, {});
    const auto call = decode_call(fields_of(frame));
    ASSERT_FALSE(call.ok());
    EXPECT_NE(call.error().message.find("exceeds the limit"), std::string::npos) << call.error().message;
}

TEST(CallFrame_test, RefusesEveryCutOfItsFields) {
    Bytes frame;
    append_call_frame(frame, 300, 70000, 1000, {});
    const ByteView fields = fields_of(frame);
    for (std::size_t n = 0; n < fields.size(); ++n)
        EXPECT_FALSE(decode_call(fields.first(n)).ok()) << n;
}

TEST(AnswerFrame_test, CarriesARecordWhenOk) {
    Bytes record;
    append_record(record, "/server", 9, 1, Bytes{0x01});
    Bytes frame;
    append_answer_frame(frame, 42, record);
    const auto answer = decode_answer(fields_of(frame));
    ASSERT_TRUE(answer.ok()) << answer.error().message;
    EXPECT_EQ(answer->id, 42u);
    EXPECT_EQ(answer->outcome, CallOutcome::ok);
    EXPECT_EQ(Bytes(answer->record.begin(), answer->record.end()), record);
}

TEST(AnswerFrame_test, CarriesAReasonWhenNot) {
    Bytes frame;
    append_failed_answer_frame(frame, 5, CallOutcome::lost, "the server's daemon went away");
    const auto answer = decode_answer(fields_of(frame));
    ASSERT_TRUE(answer.ok()) << answer.error().message;
    EXPECT_EQ(answer->outcome, CallOutcome::lost);
    EXPECT_EQ(answer->reason, "the server's daemon went away");
    EXPECT_EQ(call_outcome_name(answer->outcome), "lost");
}

TEST(AnswerFrame_test, CutsALongReasonAndRefusesBadOutcomesAndTrailingBytes) {
    Bytes frame;
    append_failed_answer_frame(frame, 5, CallOutcome::failed, std::string(10000, 'x'));
    const auto answer = decode_answer(fields_of(frame));
    ASSERT_TRUE(answer.ok());
    EXPECT_EQ(answer->reason.size(), max_error_reason);

    const Bytes bad_outcome{0x01, 0x09};
    EXPECT_FALSE(decode_answer(bad_outcome).ok());
    const Bytes trailing{0x01, 0x02, 0x01, 'a', 'z'};
    EXPECT_FALSE(decode_answer(trailing).ok());
    const Bytes cut{0x01};
    EXPECT_FALSE(decode_answer(cut).ok());
}

}  // namespace
}  // namespace plexus::proto
