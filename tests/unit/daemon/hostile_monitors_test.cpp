// The hostile corpus (tests/monitors/hostile/*.lua): each script's accept attacks the sandbox one
// way. Loaded into a Monitor with the daemon's default limits, each call must be stopped within
// its budget plus 5 ms and counted as its "-- Expect:" line says (timeout, out_of_memory, error).
#include "monitor/monitor.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "../../common/slowdown.hpp"
#include "plexus/proto/message.hpp"

namespace plexus::daemon::monitor {
namespace {

using namespace std::chrono_literals;

const std::filesystem::path corpus = std::filesystem::path(__FILE__).parent_path() / "../../monitors/hostile";

class NullHost : public MonitorHost {
public:
    proto::Status publish(Monitor&, const std::string&, const nlohmann::json&) override {
        return proto::Ok{};
    }
    void set_trig_interval(Monitor&, double) override {}
    double now() const override { return 0; }
    void monitor_gone(Monitor&) override {}
};

std::string read_text(const std::filesystem::path& path) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

/// The word after "-- Expect: " in the script's header.
std::string expected_outcome(const std::string& code) {
    const auto at = code.find("-- Expect: ");
    if (at == std::string::npos)
        return {};
    const auto start = at + std::strlen("-- Expect: ");
    return code.substr(start, code.find('\n', start) - start);
}

Message one_message() {
    const auto cbor = nlohmann::json::to_cbor(1);
    proto::Bytes bytes;
    proto::append_record(bytes, "/a", 1, 0, cbor);
    auto chunk = std::make_shared<Chunk>(bytes.size());
    std::memcpy(chunk->data(), bytes.data(), bytes.size());
    const proto::ByteView view(chunk->data(), bytes.size());  // before the chunk is moved away
    return Message{std::move(chunk), view, 1};
}

std::vector<std::string> corpus_files() {
    std::vector<std::string> names;
    for (const auto& entry : std::filesystem::directory_iterator(corpus)) {
        if (entry.path().extension() == ".lua")
            names.push_back(entry.path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

TEST(HostileMonitors_test, CorpusIsThere) {
    EXPECT_GE(corpus_files().size(), 12u) << corpus;
}

class Hostile_test : public ::testing::TestWithParam<std::string> {};

TEST_P(Hostile_test, EachCallIsStoppedWithinBudgetPlusFiveMsAndCounted) {
    const std::string code = read_text(corpus / GetParam());
    const std::string expected = expected_outcome(code);
    ASSERT_TRUE(expected == "timeout" || expected == "out_of_memory" || expected == "error")
        << GetParam() << " has no '-- Expect: timeout|out_of_memory|error' line";
    MonitorSpec spec;
    spec.script = Script{GetParam(), GetParam(), code};
    spec.source = "/a";
    spec.destination = "/b";
    spec.carrier = "tcp+recv.portmonitor+file.hostile";
    MonitorPolicy policy;  // the daemon's defaults: 16 MiB, 20 ms
    policy.quarantine_after = 100;
    const auto budget = policy.limits.budget;
    NullHost host;
    auto created = Monitor::create(spec, policy, host);
    ASSERT_TRUE(created.ok()) << created.error().message;
    auto& monitor = **created;

    // Five messages, five calls. The quickest must be within the bound; the others only within a
    // second: on this shared 2-core machine a call now and then waits a few milliseconds for the
    // processor right at its deadline, while a C function that overruns does so every time.
    constexpr int calls = 5;  // five: a loaded machine (ctest -j2 in CI) delays one now and then
    std::string times;
    auto quickest = std::chrono::steady_clock::duration::max();
    for (int i = 0; i < calls; ++i) {
        auto message = one_message();
        const auto start = std::chrono::steady_clock::now();
        EXPECT_EQ(monitor.process(message), Monitor::Verdict::drop);
        const auto elapsed = std::chrono::steady_clock::now() - start;
        EXPECT_LT(elapsed, 1s);
        quickest = std::min(quickest, elapsed);
        times += std::to_string(std::chrono::duration<double, std::milli>(elapsed).count()) + " ms ";
    }
    // A script whose header says "-- Known gap:" is one the sandbox does not yet stop in time: its
    // times are printed and only the one-second bound above applies to it.
    if (code.find("-- Known gap:") == std::string::npos)
        EXPECT_LT(quickest, budget + plexus::test::slower(5ms))
            << times;  // the slack is a speed bound, the budget not
    const auto& counters = monitor.counters();
    EXPECT_EQ(counters.errors, static_cast<std::uint64_t>(calls)) << monitor.last_error();
    if (expected == "timeout")
        EXPECT_EQ(counters.timeouts, static_cast<std::uint64_t>(calls)) << monitor.last_error();
    if (expected == "out_of_memory") {
        // A script racing to the memory cap is stopped by whichever limit it meets first: the cap
        // on a quiet machine, the budget when the copying is slowed (a loaded machine, a sanitized
        // build). Either way it is stopped and counted; a call can count as both.
        EXPECT_GE(counters.out_of_memory + counters.timeouts, static_cast<std::uint64_t>(calls))
            << monitor.last_error();
    }
    EXPECT_LE(monitor.memory_in_use(), policy.limits.memory_bytes);
    std::cout << "  " << GetParam() << ": " << times << "(" << monitor.last_error().substr(0, 70) << ")\n";
}

INSTANTIATE_TEST_SUITE_P(Corpus, Hostile_test, ::testing::ValuesIn(corpus_files()), [](const auto& info) {
    auto name = info.param.substr(0, info.param.size() - 4);
    std::replace(name.begin(), name.end(), '.', '_');
    return name;
});

}  // namespace
}  // namespace plexus::daemon::monitor
