// msg.data of a map payload, decoded a field at a time (monitor/lazy_map.hpp): it must read, write
// and convert exactly as the table an eager decoder builds, and say so when kept past its message.
#include <gtest/gtest.h>

#include "monitor_fixture.hpp"

namespace plexus::daemon::monitor {
namespace {

using LazyData_test = Fixture;

/// A one-record message whose payload is `cbor` as given (maps with integer or repeated keys,
/// malformed bytes: what json cannot express).
Message raw_message(const std::vector<std::uint8_t>& cbor) {
    proto::Bytes bytes;
    proto::append_record(bytes, "/a", 7, 1'500'000'000'000'000'000ull, cbor);
    return daemon::test::message_holding(bytes);
}

const json sample = {
    {"c", 0.9},          {"n", 3},           {"neg", -4},   {"s", "text"},
    {"yes", true},       {"none", nullptr},  {"half", 0.5}, {"blob", json::binary({1, 2, 3})},
    {"pos", {{"x", 1}}}, {"list", {1, 2, 3}}};

/// The sample without what a round trip through Lua changes anyway (lua_value.hpp: a null member
/// vanishes, a blob published without its original is text when it is valid UTF-8).
json round_trippable() {
    json value = sample;
    value.erase("none");
    value.erase("blob");
    return value;
}

/// `accept` returns `condition` on the sample: passes when it holds, errors are counted.
void expect_holds(Fixture& fixture, const std::string& condition) {
    auto monitor = fixture.make("PortMonitor.accept = function(msg) return " + condition + " end");
    ASSERT_TRUE(monitor);
    auto message = make_message(sample);
    EXPECT_EQ(monitor->process(message), Monitor::Verdict::pass)
        << condition << ": " << monitor->last_error();
    EXPECT_EQ(monitor->counters().errors, 0u) << condition << ": " << monitor->last_error();
}

TEST_F(LazyData_test, FieldsReadAsTheDecodedTableWouldHaveThem) {
    for (const char* condition : {
             "type(msg.data) == 'table'", "msg.data.c == 0.9 and math.type(msg.data.c) == 'float'",
             "msg.data.n == 3 and math.type(msg.data.n) == 'integer'", "msg.data.neg == -4",
             "msg.data.s == 'text'", "msg.data.yes == true",
             "msg.data.none == nil and msg.data.missing == nil and msg.data[1] == nil",
             "msg.data.blob == '\\1\\2\\3'", "msg.data.pos.x == 1",
             "#msg.data.list == 3 and msg.data.list[3] == 3", "msg.data.half + msg.data.c == 1.4",
             "msg.data == msg.data",  // the same table each time
         })
        expect_holds(*this, condition);
}

TEST_F(LazyData_test, PairsLengthNextAndTheRawFunctionsSeeEveryField) {
    for (const char* condition : {
             "(function() local n = 0 for _ in pairs(msg.data) do n = n + 1 end return n end)() == 9",
             "#msg.data == 0",
             "next(msg.data) ~= nil",
             "rawget(msg.data, 'c') == 0.9",
             "rawlen(msg.data) == 0",
             "getmetatable(msg.data) == nil",
             "setmetatable(msg.data, {}) ~= nil and msg.data.s == 'text'",
             "rawset(msg.data, 'c', 1) and msg.data.c == 1 and msg.data.n == 3",
             "(function() local d = msg.data; local r = d.c; d.c = nil; return r == 0.9 and d.c == nil "
             "end)()",
             "(function() local d = msg.data; for i = 1, 20 do assert(d.n == 3) end return d.s == 'text' "
             "end)()",
         })
        expect_holds(*this, condition);
}

TEST_F(LazyData_test, IntegerAndRepeatedKeysAsTheDecoderReadsThem) {
    auto monitor = make(R"(
        PortMonitor.accept = function(msg)
            return msg.data[1] == 'one' and msg.data[-2] == 'minus' and msg.data[1.0] == 'one'
                and msg.data.a == 2
        end)");
    // {1: "one", -2: "minus", "a": 1, "a": 2}: the last of a repeated key wins, as when decoded.
    auto message = raw_message({0xa4, 0x01, 0x63, 'o', 'n', 'e', 0x21, 0x65, 'm', 'i', 'n', 'u', 's', 0x61,
                                'a', 0x01, 0x61, 'a', 0x02});
    EXPECT_EQ(monitor->process(message), Monitor::Verdict::pass) << monitor->last_error();
}

TEST_F(LazyData_test, WritesAndInPlaceChangesRewriteThePayload) {
    auto added = make("PortMonitor.update = function(msg) msg.data.extra = 1; return msg end");
    auto message = make_message(round_trippable());
    ASSERT_EQ(added->process(message), Monitor::Verdict::pass);
    json expected = round_trippable();
    expected["extra"] = 1;
    EXPECT_EQ(payload_of(message), expected);
    EXPECT_EQ(added->counters().rewritten, 1u);

    auto nested = make("PortMonitor.update = function(msg) msg.data.pos.x = 5; return msg end");
    message = make_message(round_trippable());
    ASSERT_EQ(nested->process(message), Monitor::Verdict::pass);
    expected = round_trippable();
    expected["pos"]["x"] = 5;
    EXPECT_EQ(payload_of(message), expected);

    auto returned = make("PortMonitor.update = function(msg) return msg.data end");
    message = make_message(round_trippable());
    ASSERT_EQ(returned->process(message), Monitor::Verdict::pass);
    EXPECT_EQ(payload_of(message), round_trippable());

    auto published =
        make("PortMonitor.accept = function(msg) PortMonitor.publish('/p', msg.data) return true end");
    message = make_message(round_trippable());
    ASSERT_EQ(published->process(message), Monitor::Verdict::pass) << published->last_error();
    ASSERT_EQ(host.published.size(), 1u);
    EXPECT_EQ(host.published[0].second, round_trippable());
}

TEST_F(LazyData_test, ReadOnlyUpdatesLeaveThePayloadBitForBit) {
    auto monitor =
        make("PortMonitor.update = function(msg) local _ = msg.data.c + msg.data.n; return msg end");
    auto message = make_message(sample);
    const std::vector<std::uint8_t> before(message.record.begin(), message.record.end());
    ASSERT_EQ(monitor->process(message), Monitor::Verdict::pass);
    EXPECT_EQ(std::vector<std::uint8_t>(message.record.begin(), message.record.end()), before);
    EXPECT_EQ(monitor->counters().rewritten, 0u);
}

TEST_F(LazyData_test, KeptPastItsMessageItReadsNoMoreUnlessMadeATable) {
    auto monitor = make(R"(
        PortMonitor.accept = function(msg)
            if msg.seq == 1 then lazy = msg.data else
                plain = msg.data
                for _ in pairs(plain) do end  -- a plain table of the script's own
            end
            return true
        end
        PortMonitor.getparam = function() return { c = plain.c, lazy_c = lazy.c } end)");
    auto first = make_message(sample, 1);
    auto second = make_message(sample, 2);
    ASSERT_EQ(monitor->process(first), Monitor::Verdict::pass);
    ASSERT_EQ(monitor->process(second), Monitor::Verdict::pass);
    auto values = monitor->getparam();
    ASSERT_FALSE(values.ok());
    EXPECT_NE(values.error().message.find("msg.data of a message whose callbacks are over"),
              std::string::npos)
        << values.error().message;

    auto keeper = make(R"(
        PortMonitor.accept = function(msg) plain = msg.data; local _ = #plain return true end
        PortMonitor.getparam = function() return { c = plain.c } end)");
    auto message = make_message(sample);
    ASSERT_EQ(keeper->process(message), Monitor::Verdict::pass);
    auto kept = keeper->getparam();
    ASSERT_TRUE(kept.ok()) << kept.error().message;
    EXPECT_EQ((*kept)["c"], 0.9);
}

TEST_F(LazyData_test, MalformedPayloadsAreErrorsWhenRead) {
    auto monitor = make("PortMonitor.accept = function(msg) return msg.data.c ~= nil end");
    // {"c": <a float64 cut short>}, and a map followed by a stray byte.
    for (const auto& cbor : {std::vector<std::uint8_t>{0xa1, 0x61, 'c', 0xfb, 0x00},
                             std::vector<std::uint8_t>{0xa1, 0x61, 'c', 0x01, 0x01}}) {
        auto message = raw_message(cbor);
        EXPECT_EQ(monitor->process(message), Monitor::Verdict::drop);
        EXPECT_NE(monitor->last_error().find("not valid CBOR"), std::string::npos) << monitor->last_error();
    }
}

}  // namespace
}  // namespace plexus::daemon::monitor
