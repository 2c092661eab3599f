// Port monitors in isolation: life cycle, the msg object, value round trips, and every sandbox
// escape and resource attack the monitor issue lists. Scripts are given as text; the host is a fake.
#include "monitor/monitor.hpp"

#include <gtest/gtest.h>

#include <cstring>

#include "monitor_fixture.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::daemon::monitor {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

using Monitor_test = Fixture;

TEST_F(Monitor_test, CreateSeesOptionsAndCanRefuse) {
    auto monitor = make(R"(
        PortMonitor.create = function(o)
            seen = o.source .. " " .. o.destination .. " " .. o.side .. " " .. o.threshold
            return true
        end
        PortMonitor.getparam = function() return { seen = seen } end)",
                        {{"threshold", "0.8"}});
    ASSERT_TRUE(monitor);
    EXPECT_EQ((*monitor->getparam())["seen"], "/a /b recv 0.8");
    auto why = refusal("PortMonitor.create = function() return false end");
    EXPECT_NE(why.find("'test' refused the connection"), std::string::npos) << why;
}

TEST_F(Monitor_test, SyntaxAndRuntimeErrorsAtLoadNameTheFileAndLine) {
    auto syntax = refusal("PortMonitor.accept = function(msg\n  return true end");
    EXPECT_NE(syntax.find("test.lua:2:"), std::string::npos) << syntax;
    auto runtime = refusal("local x = nil\nlocal y = x.field");
    EXPECT_NE(runtime.find("test.lua:2:"), std::string::npos) << runtime;
    auto in_create = refusal("PortMonitor.create = function() error('no camera') end");
    EXPECT_NE(in_create.find("no camera"), std::string::npos) << in_create;
}

TEST_F(Monitor_test, AcceptDropsAndMsgFieldsReadLikeATable) {
    auto monitor = make(R"(
        PortMonitor.accept = function(msg)
            last = { msg.source, msg.seq, msg.time, msg.size }
            return msg.data.keep
        end
        PortMonitor.getparam = function() return { last = last } end)");
    auto keep = make_message({{"keep", true}}, 41);
    auto drop = make_message({{"keep", false}});
    EXPECT_EQ(monitor->process(keep), Monitor::Verdict::pass);
    auto last = (*monitor->getparam())["last"];
    EXPECT_EQ(last[0], "/a");
    EXPECT_EQ(last[1], 41);
    EXPECT_DOUBLE_EQ(last[2].get<double>(), 1.5e9);
    EXPECT_EQ(last[3], json::to_cbor(json{{"keep", true}}).size());
    EXPECT_EQ(monitor->process(drop), Monitor::Verdict::drop);
    EXPECT_EQ(monitor->counters().dropped, 1u);
}

TEST_F(Monitor_test, UntouchedAndReadOnlyPayloadsPassBitForBit) {
    auto monitor = make(R"(
        PortMonitor.accept = function(msg) return msg.data.n ~= nil end
        PortMonitor.update = function(msg) local _ = msg.data.blob; return msg end)");
    // A blob that is valid UTF-8, an unsigned above INT64_MAX, a float with an integral value: all
    // would change if the monitor re-encoded what it only read.
    json payload = {{"n", 1},
                    {"blob", json::binary({'a', 'b', 'c'})},
                    {"big", 18'000'000'000'000'000'000ull},
                    {"f", 2.0}};
    auto message = make_message(payload);
    const auto original = std::vector<std::uint8_t>(message.record.begin(), message.record.end());
    ASSERT_EQ(monitor->process(message), Monitor::Verdict::pass);
    EXPECT_EQ(std::vector<std::uint8_t>(message.record.begin(), message.record.end()), original);
    EXPECT_EQ(monitor->counters().rewritten, 0u);
}

TEST_F(Monitor_test, UpdateRewritesInPlaceByAssignmentOrByReturningAValue) {
    auto in_place = make("PortMonitor.update = function(msg) msg.data.x = msg.data.x * 2; return msg end");
    auto message = make_message({{"x", 21}, {"blob", json::binary({0xff, 0x00})}});
    ASSERT_EQ(in_place->process(message), Monitor::Verdict::pass);
    EXPECT_EQ(payload_of(message), json({{"x", 42}, {"blob", json::binary({0xff, 0x00})}}));

    auto assigned = make("PortMonitor.update = function(msg) msg.data = { 1, 2, 'three' } end");
    message = make_message({{"x", 1}});
    ASSERT_EQ(assigned->process(message), Monitor::Verdict::pass);
    EXPECT_EQ(payload_of(message), json::array({1, 2, "three"}));

    auto returned = make(
        "PortMonitor.update = function(msg) return { seen = msg.seq, nested = { a = { true, false } } } end");
    message = make_message("anything", 9);
    ASSERT_EQ(returned->process(message), Monitor::Verdict::pass);
    EXPECT_EQ(payload_of(message), json({{"seen", 9}, {"nested", {{"a", {true, false}}}}}));
    auto record = proto::decode_record(message.record);
    EXPECT_EQ(record->source, "/a");
    EXPECT_EQ(record->seq, 9u);
}

TEST_F(Monitor_test, JsonValuesRoundTripThroughLua) {
    auto monitor = make("PortMonitor.update = function(msg) return msg.data end");
    const json payload = {
        {"null", nullptr}, {"t", true},           {"f", false},         {"i", -12},
        {"d", 0.25},       {"s", "h\xc3\xa9llo"}, {"a", {1, 2.5, "x"}}, {"m", {{"k", {{"deep", 1}}}}}};
    auto message = make_message(payload);
    ASSERT_EQ(monitor->process(message), Monitor::Verdict::pass);
    auto back = payload_of(message);
    // Lua has no null inside tables: a null member disappears, as documented.
    json expected = payload;
    expected.erase("null");
    EXPECT_EQ(back, expected);
}

TEST_F(Monitor_test, StaleMsgAndBadAssignmentsAreErrors) {
    auto monitor = make(R"(
        PortMonitor.accept = function(msg) kept = msg; return true end
        PortMonitor.trig = function() return kept.data end)");
    auto message = make_message(1);
    EXPECT_EQ(monitor->process(message), Monitor::Verdict::pass);
    monitor->trig();
    EXPECT_NE(monitor->last_error().find("msg used after its callback returned"), std::string::npos)
        << monitor->last_error();
    auto assigns_seq = make("PortMonitor.accept = function(msg) msg.seq = 3; return true end");
    message = make_message(1);
    EXPECT_EQ(assigns_seq->process(message), Monitor::Verdict::drop);
    EXPECT_NE(assigns_seq->last_error().find("only msg.data"), std::string::npos);
}

TEST_F(Monitor_test, AcceptIsLookedUpAtEveryMessageSoAScriptMayReplaceOrRemoveIt) {
    // accept is found through the PortMonitor global at every message, as in YARP: a script that
    // swaps it, removes it, or replaces the whole table is taken at its word from the next message.
    auto monitor = make(R"(
        local n = 0
        local function odd_only(msg) return msg.data % 2 == 1 end
        PortMonitor.accept = function(msg)
            n = n + 1
            if n == 2 then PortMonitor.accept = odd_only end
            return false
        end
        PortMonitor.trig = function()
            if PortMonitor.accept == odd_only then PortMonitor.accept = nil
            else PortMonitor = nil end
        end)");
    auto verdict = [&](int value) {
        auto message = make_message(value);
        return monitor->process(message);
    };
    EXPECT_EQ(verdict(1), Monitor::Verdict::drop);  // the first accept
    EXPECT_EQ(verdict(1), Monitor::Verdict::drop);  // ... which swaps itself out after this one
    EXPECT_EQ(verdict(2), Monitor::Verdict::drop);  // odd_only
    EXPECT_EQ(verdict(3), Monitor::Verdict::pass);
    monitor->trig();  // accept removed: everything passes
    EXPECT_EQ(verdict(2), Monitor::Verdict::pass);
    monitor->trig();  // the PortMonitor table gone: everything passes, nothing fails
    for (int i = 0; i < 100; ++i)
        EXPECT_EQ(verdict(2), Monitor::Verdict::pass);
    EXPECT_EQ(monitor->counters().errors, 0u) << monitor->last_error();
}

TEST_F(Monitor_test, ThousandsOfFailingAcceptsLeaveTheStackAsItWas) {
    // Every way out of accept (an error, a wrong type, no accept at all) resets the stack: a slot
    // left behind per message would overrun the state's stack within a few dozen messages.
    auto monitor = make(R"(
        local n = 0
        PortMonitor.accept = function(msg)
            n = n + 1
            if n % 3 == 0 then error("boom") elseif n % 3 == 1 then return "yes" end
            return true
        end)");
    for (int i = 0; i < 3000; ++i) {
        auto message = make_message(i);
        monitor->process(message);
    }
    EXPECT_EQ(monitor->counters().errors, 2000u);
    auto message = make_message(1);
    EXPECT_EQ(monitor->process(message), Monitor::Verdict::drop);  // n = 3001: "yes"
}

TEST_F(Monitor_test, WrongReturnTypesAreCountedErrors) {
    auto accept_string = make("PortMonitor.accept = function(msg) return 'yes' end");
    auto message = make_message(1);
    EXPECT_EQ(accept_string->process(message), Monitor::Verdict::drop);
    EXPECT_EQ(accept_string->counters().errors, 1u);
    EXPECT_NE(accept_string->last_error().find("accept must return true or false"), std::string::npos);

    auto update_function = make("PortMonitor.update = function(msg) return print end");
    message = make_message(1);
    const auto before = std::vector<std::uint8_t>(message.record.begin(), message.record.end());
    EXPECT_EQ(update_function->process(message), Monitor::Verdict::pass);  // update errors pass the original
    EXPECT_EQ(std::vector<std::uint8_t>(message.record.begin(), message.record.end()), before);
    EXPECT_EQ(update_function->counters().errors, 1u);

    auto getparam_number = make("PortMonitor.getparam = function() return 5 end");
    EXPECT_FALSE(getparam_number->getparam().ok());
}

TEST_F(Monitor_test, OnErrorClauseOverridesTheDefault) {
    auto spec = spec_for("PortMonitor.accept = function(msg) error('boom') end");
    spec.on_error = OnError::pass;
    auto monitor = std::move(*Monitor::create(std::move(spec), test_policy(), host));
    auto message = make_message(1);
    EXPECT_EQ(monitor->process(message), Monitor::Verdict::pass);
    auto spec2 = spec_for("PortMonitor.update = function(msg) error('boom') end");
    spec2.on_error = OnError::drop;
    auto monitor2 = std::move(*Monitor::create(std::move(spec2), test_policy(), host));
    EXPECT_EQ(monitor2->process(message), Monitor::Verdict::drop);
}

TEST_F(Monitor_test, RuntimeErrorsInEachCallbackAreCountedWithATraceback) {
    auto monitor = make(R"(
        local function fail(where) error("failed in " .. where) end
        PortMonitor.accept = function(msg) if msg.data == 1 then fail("accept") end return true end
        PortMonitor.update = function(msg) if msg.data == 2 then fail("update") end return msg end
        PortMonitor.trig = function() fail("trig") end
        PortMonitor.setparam = function(t) fail("setparam") end
        PortMonitor.getparam = function() fail("getparam") end)");
    auto one = make_message(1);
    EXPECT_EQ(monitor->process(one), Monitor::Verdict::drop);
    EXPECT_NE(monitor->last_error().find("failed in accept"), std::string::npos);
    EXPECT_NE(monitor->last_error().find("stack traceback"), std::string::npos) << monitor->last_error();
    auto two = make_message(2);
    EXPECT_EQ(monitor->process(two), Monitor::Verdict::pass);
    EXPECT_NE(monitor->last_error().find("failed in update"), std::string::npos);
    auto three = make_message(3);
    EXPECT_EQ(monitor->process(three), Monitor::Verdict::pass);  // a success resets the failure run
    monitor->trig();
    EXPECT_FALSE(monitor->setparam(json{{"a", 1}}).ok());
    EXPECT_EQ(monitor->counters().errors, 4u);
    EXPECT_FALSE(monitor->quarantined());
}

TEST_F(Monitor_test, SandboxHasNoWayOut) {
    auto monitor = make(R"(
        local function probe(f) local ok, err = pcall(f); return ok and "open" or tostring(err) end
        PortMonitor.getparam = function()
            return {
                io = tostring(io), os = tostring(os), package = tostring(package),
                require_os = probe(function() return require("os") end),
                debug = tostring(debug), dofile = tostring(dofile),
                loadfile = tostring(loadfile), dump = tostring(string.dump),
                collectgarbage = tostring(collectgarbage),
                execute = probe(function() return os.execute("true") end),
                loadlib = probe(function() return package.loadlib("libc.so.6", "system") end),
                bytecode = probe(function() return assert(load("\27Lua\84\0\25\147\r\n\26\n")) end),
                bytecode_mode = probe(function() return assert(load("\27Lua", "x", "b")) end),
                text = probe(function() return assert(load("return 1"))() end),
                string_meta = probe(function() return getmetatable("").__index.dump("x") end),
            }
        end)");
    auto seen = *monitor->getparam();
    for (const char* name : {"io", "os", "package", "debug", "dofile", "loadfile", "dump", "collectgarbage"})
        EXPECT_EQ(seen[name], "nil") << name;
    // require exists for YARP's scripts, and gives nothing but the yarp module.
    for (const char* attempt :
         {"execute", "loadlib", "bytecode", "bytecode_mode", "string_meta", "require_os"})
        EXPECT_NE(seen[attempt], "open") << attempt << ": " << seen[attempt];
    EXPECT_NE(seen["bytecode"].get<std::string>().find("binary chunk"), std::string::npos)
        << seen["bytecode"];
    EXPECT_EQ(seen["text"], "open");  // load of text stays available
}

class Budget_test : public Fixture, public ::testing::WithParamInterface<const char*> {};

TEST_P(Budget_test, InfiniteLoopsEndAtTheBudgetEvenInsidePcall) {
    // Each script loops forever in accept, update or trig, bare or behind pcall / coroutines.
    auto monitor = make(GetParam());
    ASSERT_TRUE(monitor);
    auto message = make_message(1);
    const auto start = std::chrono::steady_clock::now();
    monitor->process(message);
    monitor->trig();
    const auto elapsed = std::chrono::steady_clock::now() - start;
    EXPECT_EQ(monitor->counters().timeouts, 1u) << monitor->last_error();
    EXPECT_NE(monitor->last_error().find("time budget"), std::string::npos) << monitor->last_error();
    EXPECT_LT(elapsed, 5s);  // a generous bound: the budget is 50 ms; this only catches a hang
}

INSTANTIATE_TEST_SUITE_P(
    Loops, Budget_test,
    ::testing::Values(
        "PortMonitor.accept = function(msg) while true do end end",
        "PortMonitor.update = function(msg) while true do end end",
        "PortMonitor.trig = function() while true do end end",
        "PortMonitor.accept = function(msg) while true do pcall(function() while true do end end) end end",
        "PortMonitor.update = function(msg) while true do pcall(pcall, function() while true do end end) end "
        "end",
        "PortMonitor.trig = function() while true do xpcall(function() while true do end end, function(e) "
        "return e end) end end",
        "PortMonitor.accept = function(msg) local co = coroutine.create(function() while true do end end)\n"
        "  while true do coroutine.resume(co) end end",
        "PortMonitor.accept = function(msg) while true do pcall(string.rep, 'x', 10) end end"));

TEST_F(Monitor_test, MemoryCapRefusesHugeStringsAndGrowingTables) {
    auto monitor = make(R"(
        PortMonitor.accept = function(msg)
            if msg.data == 1 then local s = string.rep("x", 2^30) end
            if msg.data == 2 then local t = {} while true do t[#t + 1] = { 1, 2, 3 } end end
            if msg.data == 3 then big = {} for i = 1, 1e9 do big[i] = i end end
            return true
        end)");
    for (int i = 1; i <= 3; ++i) {
        auto message = make_message(i);
        EXPECT_EQ(monitor->process(message), Monitor::Verdict::drop);
        EXPECT_LE(monitor->memory_in_use(), test_policy().limits.memory_bytes);
    }
    EXPECT_EQ(monitor->counters().out_of_memory, 3u) << monitor->last_error();
}

TEST_F(Monitor_test, RepeatedFailuresQuarantineAndFreeTheState) {
    auto monitor = make(R"(
        PortMonitor.accept = function(msg) hoard = hoard or {} for i = 1, 1e9 do hoard[#hoard+1] = i end end)");
    auto message = make_message(1);
    for (int i = 0; i < 3; ++i)
        EXPECT_EQ(monitor->process(message), Monitor::Verdict::drop);
    EXPECT_TRUE(monitor->quarantined());
    EXPECT_EQ(monitor->memory_in_use(), 0u);
    EXPECT_EQ(host.gone, 1);
    // Quarantined: no script runs, the accept default (drop) applies, and it is counted.
    EXPECT_EQ(monitor->process(message), Monitor::Verdict::drop);
    EXPECT_EQ(monitor->counters().errors, 3u);
    EXPECT_EQ(monitor->counters().dropped, 4u);
    EXPECT_FALSE(monitor->getparam().ok());
}

TEST_F(Monitor_test, HostFunctionsPublishTimersAndClock) {
    auto monitor = make(R"(
        PortMonitor.create = function() PortMonitor.setTrigInterval(0.033) return true end
        PortMonitor.trig = function() PortMonitor.publish("/evt", { at = PortMonitor.now(), list = { 1, 2 } }) end
        PortMonitor.accept = function(msg) PortMonitor.publish("bad name", 1) return true end)");
    EXPECT_DOUBLE_EQ(host.trig_interval, 0.033);  // seconds, not milliseconds
    monitor->trig();
    ASSERT_EQ(host.published.size(), 1u);
    EXPECT_EQ(host.published[0].first, "/evt");
    EXPECT_EQ(host.published[0].second, json({{"at", 1000.0}, {"list", {1, 2}}}));
    auto message = make_message(1);
    EXPECT_EQ(monitor->process(message), Monitor::Verdict::drop);
    EXPECT_NE(monitor->last_error().find("publish to 'bad name' refused"), std::string::npos)
        << monitor->last_error();
    auto bad_interval = refusal("PortMonitor.create = function() PortMonitor.setTrigInterval(-1) end");
    EXPECT_NE(bad_interval.find("setTrigInterval"), std::string::npos);
}

TEST_F(Monitor_test, DestroyRunsWhenTheMonitorGoes) {
    auto monitor = make("PortMonitor.destroy = function() PortMonitor.publish('/bye', true) end");
    monitor.reset();
    ASSERT_EQ(host.published.size(), 1u);
    EXPECT_EQ(host.published[0].first, "/bye");
    EXPECT_EQ(host.gone, 1);
}

TEST_F(Monitor_test, AScriptThatReplacesPortMonitorKeepsTheApi) {
    auto monitor = make(R"(
        PortMonitor = {}
        function PortMonitor.trig() PortMonitor.publish("/x", 1) end)");
    monitor->trig();
    EXPECT_EQ(host.published.size(), 1u) << monitor->last_error();
}

}  // namespace
}  // namespace plexus::daemon::monitor

namespace plexus::daemon::monitor {
namespace {

/// A host whose publish calls back into the publishing monitor, as a call nested in the script's.
class ReenteringHost : public FakeHost {
public:
    proto::Status publish(Monitor& monitor, const std::string& port, const json& value) override {
        auto nested = monitor.getparam();
        nested_result = nested.ok() ? nested->dump() : nested.error().message;
        return FakeHost::publish(monitor, port, value);
    }
    std::string nested_result;
};

TEST(MonitorNesting_test, ACallNestedInTheScriptsOwnCallReportsItsErrorWithATraceback) {
    // The handler of the outer calls sits at the bottom of the Lua stack; a nested call must not
    // take index 1 of its C frame (publish's first argument) for it.
    ReenteringHost host;
    auto created = Monitor::create(spec_for(R"(
        PortMonitor.getparam = function() error("no parameters while publishing") end
        PortMonitor.accept = function(msg) PortMonitor.publish("/a/event", 1) return true end)"),
                                   test_policy(), host);
    ASSERT_TRUE(created.ok()) << created.error().message;
    auto message = make_message(json{{"c", 1}});
    EXPECT_EQ((*created)->process(message), Monitor::Verdict::pass);
    EXPECT_NE(host.nested_result.find("no parameters while publishing"), std::string::npos)
        << host.nested_result;
    EXPECT_NE(host.nested_result.find("stack traceback"), std::string::npos) << host.nested_result;
    // And the outer call still works afterwards.
    EXPECT_EQ((*created)->process(message), Monitor::Verdict::pass);
    ASSERT_EQ(host.published.size(), 2u);
}

TEST_F(Monitor_test, OnlyStrictUtf8BecomesTextOtherStringsBlobs) {
    // The lua_value fuzz target found U+119F3C (f4 99 bc bc, above U+10FFFF) written as a CBOR
    // text string, which decoders refuse; surrogates and overlong forms likewise.
    const std::pair<const char*, bool> cases[] = {
        {"'\\195\\169'", true},             // U+00E9
        {"'\\244\\143\\191\\191'", true},   // U+10FFFF
        {"'\\244\\153\\188\\188'", false},  // above U+10FFFF
        {"'\\237\\160\\128'", false},       // a surrogate
        {"'\\224\\128\\175'", false},       // an overlong '/'
        {"'\\240\\130\\130\\172'", false},  // an overlong euro sign
    };
    for (const auto& [literal, text] : cases) {
        auto monitor = make(std::string("PortMonitor.update = function(msg) return ") + literal + " end");
        auto message = make_message(json{{"x", 1}});
        ASSERT_EQ(monitor->process(message), Monitor::Verdict::pass) << literal;
        const auto payload = payload_of(message);
        EXPECT_EQ(payload.is_string(), text) << literal << " became " << payload.dump();
        EXPECT_EQ(payload.is_binary(), !text) << literal;
    }
}

}  // namespace
}  // namespace plexus::daemon::monitor
