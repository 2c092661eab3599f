// A batch through a connection's recv-side monitors: every record judged on its own, the runs of
// records passed unchanged delivered as smaller batches, the counters per record.
#include "core/inlet.hpp"

#include <gtest/gtest.h>

#include <cstring>

#include "arbitration/clock.hpp"
#include "monitor/chain.hpp"
#include "monitor/stage.hpp"
#include "test_messages.hpp"

namespace plexus::daemon {
namespace {

using namespace std::chrono_literals;

class QuietHost : public monitor::MonitorHost {
public:
    proto::Status publish(monitor::Monitor&, const std::string&, const nlohmann::json&) override {
        return proto::Ok{};
    }
    void set_trig_interval(monitor::Monitor&, double) override {}
    double now() const override { return 0; }
    void monitor_gone(monitor::Monitor&) override {}
};

using test::seqs_of;

/// A batch of records from /a with seq 1..n (payload: the CBOR of the seq).
Message batch_of(std::uint32_t n) {
    return test::batch_of(n, "/a", [](std::uint32_t seq) { return nlohmann::json::to_cbor(seq); });
}

struct Inlet_test : ::testing::Test {
    QuietHost host;
    asio::io_context io;
    std::shared_ptr<monitor::Workers> workers = std::make_shared<monitor::Workers>(1);
    arbitration::ManualClock clock;
    std::shared_ptr<arbitration::Arbiter> arbiter = std::make_shared<arbitration::Arbiter>(clock);
    std::shared_ptr<Port> port = std::make_shared<Port>("/b", 1, QueuePolicy::strict, 100);
    std::vector<std::shared_ptr<monitor::MonitorStage>> stages;

    /// Like the daemon at its end: the monitors go on their worker while `host` still exists.
    void TearDown() override {
        for (auto& stage : stages)
            stage->close();
        workers->finish();
    }

    std::shared_ptr<Inlet> inlet_with(const std::string& script,
                                      monitor::MonitorStage::Options options = {}) {
        auto member = std::make_shared<arbitration::Member>(arbiter, "/a");
        auto inlet = std::make_shared<Inlet>(port, "/a", "local+recv.portmonitor+file.t", member);
        monitor::MonitorSpec spec;
        spec.script = monitor::Script{"t", "t.lua", script};
        spec.side = proto::Side::recv;
        spec.source = "/a";
        spec.destination = "/b";
        monitor::MonitorPolicy policy;
        policy.limits.memory_bytes = 4u << 20;
        policy.limits.budget = 50ms;
        auto created = monitor::Monitor::create(spec, policy, host);
        EXPECT_TRUE(created.ok()) << (created.ok() ? "" : created.error().message);
        auto chain = std::make_shared<monitor::MonitorChain>();
        chain->monitors.push_back(std::move(*created));
        auto stage = std::make_shared<monitor::MonitorStage>(workers, io.get_executor(), chain, member,
                                                             options, nullptr);
        stage->attach(inlet);
        inlet->monitors = stage;
        stages.push_back(stage);
        return inlet;
    }

    /// The monitors run on a worker; their verdicts come back through `io`.
    void wait_for_verdicts(const Inlet& inlet) {
        const auto deadline = std::chrono::steady_clock::now() + 10s;
        while (inlet.monitors->in_flight() > 0 && std::chrono::steady_clock::now() < deadline) {
            io.restart();
            io.run_for(10ms);
        }
        ASSERT_EQ(inlet.monitors->in_flight(), 0u) << "verdicts did not come back within 10 s";
    }

    std::vector<std::vector<std::uint64_t>> queued() {
        std::vector<std::vector<std::uint64_t>> entries;
        while (!port->queue().empty())
            entries.push_back(seqs_of(port->queue().pop()));
        return entries;
    }
};

TEST_F(Inlet_test, RecordsAMonitorPassesUnchangedStayTogetherBetweenTheOnesItDrops) {
    auto inlet = inlet_with("PortMonitor.accept = function(msg) return msg.seq % 3 ~= 0 end");
    inlet->deliver(batch_of(7));
    wait_for_verdicts(*inlet);
    EXPECT_EQ(inlet->received, 7u);
    EXPECT_EQ(inlet->dropped_by_accept, 2u);
    EXPECT_EQ(inlet->accepted, 5u);
    EXPECT_EQ(inlet->delivered, 5u);
    EXPECT_EQ(port->queue().depth(), 5u);
    using Seqs = std::vector<std::uint64_t>;
    EXPECT_EQ(queued(), (std::vector<Seqs>{{1, 2}, {4, 5}, {7}}));
}

TEST_F(Inlet_test, ARewrittenRecordLeavesOnItsOwnAndEndsTheRun) {
    auto inlet = inlet_with(R"(
        PortMonitor.update = function(msg)
            if msg.seq == 2 then msg.data = 200 end
            return msg
        end)");
    inlet->deliver(batch_of(4));
    wait_for_verdicts(*inlet);
    EXPECT_EQ(inlet->delivered, 4u);
    const auto entries = [&] {
        std::vector<Message> all;
        while (!port->queue().empty())
            all.push_back(port->queue().pop());
        return all;
    }();
    ASSERT_EQ(entries.size(), 3u);
    EXPECT_EQ(seqs_of(entries[0]), (std::vector<std::uint64_t>{1}));
    EXPECT_EQ(entries[1].batch, 0u) << "the rewritten message is a record of its own";
    const auto rewritten = proto::decode_record(entries[1].record);
    EXPECT_EQ(rewritten->seq, 2u);
    EXPECT_EQ(nlohmann::json::from_cbor(rewritten->payload.begin(), rewritten->payload.end()), 200);
    EXPECT_EQ(seqs_of(entries[2]), (std::vector<std::uint64_t>{3, 4}));
}

TEST_F(Inlet_test, MessagesKeepTheirOrderWhileTheMonitorsMoveBetweenTheLoopAndAWorker) {
    // A script whose cost swings across the inline limit every thousand messages: the stage moves
    // its monitors from the daemon's thread to a worker and back many times over, and every
    // message must still reach the port in the order it came (a worker's verdicts, posted back to
    // the loop, once trailed the first inline drain after the move back).
    workers = std::make_shared<monitor::Workers>(1, &io);
    port = std::make_shared<Port>("/b", 1, QueuePolicy::strict, 1'000'000);
    monitor::MonitorStage::Options options;
    options.inline_cost_limit = 4us;
    auto inlet = inlet_with(R"(
        local n = 0
        PortMonitor.accept = function(msg)
            n = n + 1
            if (n // 1000) % 2 == 1 then
                local x = 0
                for i = 1, 500 do x = x + i end
            end
            return true
        end)",
                            options);
    constexpr std::uint64_t count = 30'000;
    const auto* stage = monitor::stage_of(inlet->monitors);
    bool was_inline = stage->runs_inline();
    int moves = 0;
    std::uint64_t next = 1;
    const auto deadline = std::chrono::steady_clock::now() + 60s;
    while (next <= count && std::chrono::steady_clock::now() < deadline) {
        // A few at a time, as a session's reads bring them, with the loop's handlers in between.
        for (int i = 0; i < 3 && next <= count && inlet->room() > 0; ++i, ++next)
            inlet->deliver(test::json_message(next, next));
        io.restart();
        io.poll();
        moves += stage->runs_inline() != was_inline;
        was_inline = stage->runs_inline();
    }
    wait_for_verdicts(*inlet);
    ASSERT_EQ(inlet->delivered, count);
    std::uint64_t expected = 1;
    std::uint64_t out_of_order = 0;
    for (const auto& entry : queued()) {
        for (const auto seq : entry) {
            if (seq != expected)
                ++out_of_order;
            expected = seq + 1;
        }
    }
    EXPECT_EQ(out_of_order, 0u);
    // The moves follow measured cost, which a loaded machine inflates (a worker preempted in a
    // drain): too few of them, and nothing was proven either way.
    if (moves < 2)
        GTEST_SKIP() << "the monitors moved " << moves << " times (fewer than a move to a worker and back)";
}

}  // namespace
}  // namespace plexus::daemon

namespace plexus::daemon {
namespace {

/// Keeps what a tap is told: the seq of each arrival, and each decision with its seqs.
struct KeepingTap : PortTap {
    std::vector<std::uint64_t> arrivals;
    std::vector<std::pair<std::vector<std::uint64_t>, TapDecision>> decisions;
    void arrived(const Inlet&, const Message& message) override {
        for (const auto seq : seqs_of(message))
            arrivals.push_back(seq);
        ++arrival_calls;
    }
    std::size_t arrival_calls = 0;
    void decided(const Inlet&, const Message& message, const TapDecision& decision) override {
        decisions.emplace_back(seqs_of(message), decision);
    }
};

TEST_F(Inlet_test, ATapSeesEveryRecordOfABatchAndWhatTheMonitorsAndTheArbitrationDecided) {
    auto tap = std::make_shared<KeepingTap>();
    port->tap = tap;
    arbiter->set_watched(true);
    clock.set(50);
    auto inlet = inlet_with("PortMonitor.accept = function(msg) return msg.seq % 3 ~= 0 end");
    inlet->deliver(batch_of(4));
    wait_for_verdicts(*inlet);
    EXPECT_EQ(tap->arrivals, (std::vector<std::uint64_t>{1, 2, 3, 4}));
    EXPECT_EQ(tap->arrival_calls, 1u) << "the batch arrives whole";
    ASSERT_EQ(tap->decisions.size(), 4u) << "one decision per record while tapped, no runs";
    using Outcome = TapDecision::Outcome;
    const std::vector<Outcome> outcomes{Outcome::delivered, Outcome::delivered, Outcome::accept,
                                        Outcome::delivered};
    for (std::size_t i = 0; i < 4; ++i) {
        EXPECT_EQ(tap->decisions[i].first, (std::vector<std::uint64_t>{i + 1}));
        EXPECT_EQ(tap->decisions[i].second.outcome, outcomes[i]) << "seq " << i + 1;
        EXPECT_EQ(tap->decisions[i].second.monitor_time, 50) << "the arbitration clock, noted";
        EXPECT_EQ(tap->decisions[i].second.decision_time, 50);
    }
    EXPECT_EQ(port->queue().depth(), 3u);
}

TEST_F(Inlet_test, WithoutMonitorsATapSeesTheArbitrationsReasonForARefusal) {
    auto tap = std::make_shared<KeepingTap>();
    port->tap = tap;
    auto member = std::make_shared<arbitration::Member>(arbiter, "/a");
    member->constraint = *arbitration::Constraint::parse("e_seen");
    auto inlet = std::make_shared<Inlet>(port, "/a", "local", member);
    clock.set(7);
    inlet->deliver(test::batch_of(1, "/a", [](std::uint32_t seq) { return nlohmann::json::to_cbor(seq); }));
    ASSERT_EQ(tap->decisions.size(), 1u);
    EXPECT_EQ(tap->decisions[0].second.outcome, TapDecision::Outcome::constraint);
    EXPECT_EQ(tap->decisions[0].second.decision_time, 7);
    EXPECT_EQ(port->queue().depth(), 0u);
}

TEST_F(Inlet_test, WithATapAndNothingToDecideABatchStillPassesWholeAndIsDecidedWhole) {
    auto tap = std::make_shared<KeepingTap>();
    port->tap = tap;
    auto member = std::make_shared<arbitration::Member>(arbiter, "/a");
    auto inlet = std::make_shared<Inlet>(port, "/a", "local", member);
    inlet->deliver(batch_of(3));
    EXPECT_EQ(tap->arrival_calls, 1u);
    ASSERT_EQ(tap->decisions.size(), 1u);
    EXPECT_EQ(tap->decisions[0].first, (std::vector<std::uint64_t>{1, 2, 3}));
    EXPECT_EQ(tap->decisions[0].second.outcome, TapDecision::Outcome::delivered);
    EXPECT_EQ(queued(), (std::vector<std::vector<std::uint64_t>>{{1, 2, 3}}));
}

TEST_F(Inlet_test, WithoutATapABatchStillPassesWhole) {
    auto member = std::make_shared<arbitration::Member>(arbiter, "/a");
    auto inlet = std::make_shared<Inlet>(port, "/a", "local", member);
    inlet->deliver(batch_of(5));
    ASSERT_EQ(port->queue().depth(), 5u);
    EXPECT_EQ(queued(), (std::vector<std::vector<std::uint64_t>>{{1, 2, 3, 4, 5}}));
}

}  // namespace
}  // namespace plexus::daemon
