// libplexus outlives its daemon: kill -9 plexusd mid-stream, start it again on the same socket and
// addresses, and the stream resumes with nothing done by the component; a daemon that never
// returns leaves writes bounded and requests failing with a clear reason.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <set>
#include <vector>

#include "harness.hpp"
#include "plexus/client.hpp"

namespace reconnect_test {

using namespace plexus;
using namespace plexus::test;
using Clock = std::chrono::steady_clock;

/// States a Client told its on_state callback, in order.
class StateLog {
public:
    explicit StateLog(Client& client) {
        client.on_state([this](ConnectionState state) {
            std::lock_guard lock(mutex_);
            states_.push_back(state);
        });
    }
    std::vector<ConnectionState> states() const {
        std::lock_guard lock(mutex_);
        return states_;
    }

private:
    mutable std::mutex mutex_;
    std::vector<ConnectionState> states_;
};

void expect_gone_error(const std::function<void()>& request, const std::string& socket) {
    try {
        request();
        ADD_FAILURE() << "a request succeeded while the daemon was away";
    } catch (const Error& error) {
        EXPECT_EQ(error.code(), ErrorCode::refused);
        EXPECT_EQ(std::string(error.what()), "the daemon at " + socket + " is gone; reconnecting");
    }
}

TEST(Reconnect_test, AStreamResumesByItselfAfterItsDaemonIsKilledAndStartedAgain) {
    TempDir dir;
    Daemon daemon(dir, "node");
    Client writing({daemon.socket()});
    Client reading({daemon.socket()});
    StateLog writer_states(writing);
    StateLog reader_states(reading);
    auto source = writing.open("/again/source");
    auto sink = reading.open("/again/sink");
    writing.connect("/again/source", "/again/sink");

    std::vector<std::uint64_t> seqs;  // as received, in order
    const auto read_until = [&](std::uint64_t last, std::chrono::milliseconds timeout,
                                std::optional<Clock::time_point>* first_after = nullptr,
                                std::uint64_t after = 0) {
        const auto deadline = Clock::now() + timeout;
        while ((seqs.empty() || seqs.back() < last) && Clock::now() < deadline) {
            if (auto message = sink.read(200ms)) {
                EXPECT_EQ(message->data.get<std::uint64_t>(), message->envelope.seq);
                seqs.push_back(message->envelope.seq);
                if (first_after && !*first_after && message->envelope.seq > after)
                    *first_after = Clock::now();
            }
        }
        return !seqs.empty() && seqs.back() >= last;
    };

    // Before: 1..200 arrive, read as they come.
    for (std::uint64_t i = 1; i <= 200; ++i)
        source.write(i);
    ASSERT_TRUE(read_until(200, 10s));

    // Mid-stream: 201..300 written and not read yet when the daemon is killed.
    for (std::uint64_t i = 201; i <= 300; ++i)
        source.write(i);
    daemon.process().signal(SIGKILL);
    ASSERT_TRUE(daemon.process().wait(10s).has_value());

    // While it is away: writes neither throw nor block, and are held; requests say why they fail.
    ASSERT_TRUE(eventually([&] {
        return writing.state() == ConnectionState::disconnected &&
               reading.state() == ConnectionState::disconnected;
    }));
    const auto writes_began = Clock::now();
    for (std::uint64_t i = 301; i <= 350; ++i)
        source.write(i);
    EXPECT_LT(Clock::now() - writes_began, 1s);
    expect_gone_error([&] { writing.stats(); }, daemon.socket());
    expect_gone_error([&] { writing.connect("/again/source", "/again/sink"); }, daemon.socket());
    // Reads take what reached the reader before the daemon went, then wait (and do not throw).
    while (auto message = sink.read(50ms))
        seqs.push_back(message->envelope.seq);
    const auto waited = Clock::now();
    EXPECT_FALSE(sink.read(50ms).has_value());
    EXPECT_GE(Clock::now() - waited, 50ms);

    const auto restarted = Clock::now();
    daemon.start_again();
    std::optional<Clock::time_point> first_after;
    ASSERT_TRUE(read_until(350, 30s, &first_after, 300))
        << "received up to " << (seqs.empty() ? 0 : seqs.back()) << "; " << daemon.process().err();
    ASSERT_TRUE(first_after.has_value());
    const auto resumed_ms =
        std::chrono::duration_cast<std::chrono::milliseconds>(*first_after - restarted).count();

    // Afterwards: the same Port objects keep working.
    for (std::uint64_t i = 351; i <= 400; ++i)
        source.write(i);
    ASSERT_TRUE(read_until(400, 10s));

    // Order kept, nothing twice, sequence numbers continued.
    EXPECT_TRUE(std::is_sorted(seqs.begin(), seqs.end()));
    EXPECT_EQ(std::set<std::uint64_t>(seqs.begin(), seqs.end()).size(), seqs.size());
    std::vector<std::uint64_t> missing;
    for (std::uint64_t i = 1, at = 0; i <= 400; ++i) {
        if (at < seqs.size() && seqs[at] == i)
            ++at;
        else
            missing.push_back(i);
    }
    // Lost: only messages written before the kill (inside the killed daemon), one contiguous range.
    if (!missing.empty()) {
        EXPECT_GT(missing.front(), 200u);
        EXPECT_LE(missing.back(), 300u);
        std::string list;
        for (const auto seq : missing)
            list += std::to_string(seq) + " ";
        EXPECT_EQ(missing.back() - missing.front() + 1, missing.size())
            << "the loss is not contiguous: " << list;
    }
    EXPECT_EQ(source.dropped_while_disconnected(), 0u);

    const std::vector<ConnectionState> expected{ConnectionState::disconnected, ConnectionState::reconnected};
    // The held messages go out before the reconnection is announced (DaemonLink::restore, then
    // announce): a reader can have them all while the writer's thread has yet to say so.
    EXPECT_TRUE(eventually([&] { return writer_states.states().size() >= expected.size(); }));
    EXPECT_TRUE(eventually([&] { return reader_states.states().size() >= expected.size(); }));
    EXPECT_EQ(writer_states.states(), expected);
    EXPECT_EQ(reader_states.states(), expected);
    EXPECT_EQ(writing.state(), ConnectionState::reconnected);
    EXPECT_NO_THROW(writing.stats());

    std::printf(
        "[ reconnect ] lost %zu message(s) inside the killed daemon (seq %llu..%llu); first message "
        "%lld ms after plexusd was started again\n",
        missing.size(), missing.empty() ? 0ULL : static_cast<unsigned long long>(missing.front()),
        missing.empty() ? 0ULL : static_cast<unsigned long long>(missing.back()),
        static_cast<long long>(resumed_ms));
}

TEST(Reconnect_test, AClientWhoseDaemonNeverReturnsKeepsWritesBoundedAndSaysWhyRequestsFail) {
    TempDir dir;
    Daemon daemon(dir, "gone");
    Client client({daemon.socket()});
    StateLog states(client);
    auto small = client.open("/gone/small");
    auto large = client.open("/gone/large");

    daemon.process().signal(SIGKILL);
    ASSERT_TRUE(daemon.process().wait(10s).has_value());
    ASSERT_TRUE(eventually([&] { return client.state() == ConnectionState::disconnected; }));

    const auto began = Clock::now();
    for (std::uint64_t i = 1; i <= 1500; ++i)
        small.write(i);  // at most 1,000 are kept: the oldest 500 go
    const std::vector<std::uint8_t> blob(1000 * 1000, 7);
    for (int i = 0; i < 9; ++i)
        large.write(Value::binary(blob));  // at most 8 MiB are kept: the oldest one goes
    const auto took = Clock::now() - began;
    EXPECT_LT(took, 2s) << "writes while the daemon is away must not block";
    EXPECT_EQ(small.dropped_while_disconnected(), 500u);
    EXPECT_EQ(large.dropped_while_disconnected(), 1u);

    expect_gone_error([&] { client.stats(); }, daemon.socket());
    expect_gone_error([&] { client.open("/gone/new"); }, daemon.socket());
    expect_gone_error([&] { client.connect("/gone/small", "/gone/large"); }, daemon.socket());
    const auto read_began = Clock::now();
    EXPECT_FALSE(small.read(100ms).has_value());
    EXPECT_GE(Clock::now() - read_began, 100ms) << "a read waits for its timeout rather than failing";
    EXPECT_EQ(states.states(), std::vector<ConnectionState>{ConnectionState::disconnected});
    std::printf("[ reconnect ] 1,509 writes with no daemon took %.1f ms\n",
                std::chrono::duration<double, std::milli>(took).count());
}

}  // namespace reconnect_test
