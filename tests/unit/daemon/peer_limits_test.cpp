// What one peer may hold of the daemon at once (net/peer_limits.hpp): connections, handshakes in
// flight, failed proofs of the secret in a minute; and that everything counted goes with the
// connections, so that the table never keeps a peer that has nothing open.
#include <gtest/gtest.h>

#include <chrono>
#include <memory>
#include <vector>

#include "net/peer_limits.hpp"

namespace plexus::daemon {
namespace {

using Refusal = PeerLimits::Refusal;
using namespace std::chrono_literals;

std::shared_ptr<PeerLimits> limits(std::size_t connections, std::size_t handshakes,
                                   std::size_t failed_proofs) {
    return std::make_shared<PeerLimits>(PeerLimitConfig{connections, handshakes, failed_proofs});
}

TEST(PeerLimits_test, HandshakesInFlightAreBoundedAndFreedByFinishingThem) {
    auto table = limits(100, 2, 10);
    auto first = table->admit("ip 10.0.0.1");
    auto second = table->admit("ip 10.0.0.1");
    ASSERT_TRUE(first.ticket && second.ticket);
    EXPECT_EQ(table->admit("ip 10.0.0.1").refusal, Refusal::handshakes);
    EXPECT_TRUE(table->admit("ip 10.0.0.2").ticket) << "another peer has limits of its own";
    first.ticket->handshake_done();
    first.ticket->handshake_done();  // twice counts once
    auto third = table->admit("ip 10.0.0.1");
    EXPECT_TRUE(third.ticket);
    EXPECT_EQ(table->admit("ip 10.0.0.1").refusal, Refusal::handshakes);
}

TEST(PeerLimits_test, OpenConnectionsAreBoundedAndFreedByClosingThem) {
    auto table = limits(3, 10, 10);
    std::vector<std::unique_ptr<PeerLimits::Ticket>> open;
    for (int i = 0; i < 3; ++i) {
        auto admitted = table->admit("uid 1000");
        ASSERT_TRUE(admitted.ticket);
        admitted.ticket->handshake_done();
        open.push_back(std::move(admitted.ticket));
    }
    const auto refused = table->admit("uid 1000");
    EXPECT_EQ(refused.refusal, Refusal::connections);
    EXPECT_FALSE(refused.ticket);
    EXPECT_NE(table->explain(refused.refusal).find("peer_connections"), std::string::npos);
    open.pop_back();
    EXPECT_TRUE(table->admit("uid 1000").ticket);
}

TEST(PeerLimits_test, FailedProofsShutThePeerOutUntilTheOldestIsAMinuteOld) {
    auto table = limits(100, 100, 3);
    const auto start = PeerLimits::Clock::now();
    for (int i = 0; i < 3; ++i) {
        auto admitted = table->admit("ip 10.0.0.9", start);
        ASSERT_TRUE(admitted.ticket) << i;
        admitted.ticket->proof_failed(start + std::chrono::seconds(i));
    }  // each ticket goes: its connection closed after the failure
    EXPECT_EQ(table->admit("ip 10.0.0.9", start + 10s).refusal, Refusal::failed_proofs);
    EXPECT_EQ(table->admit("ip 10.0.0.9", start + 59s).refusal, Refusal::failed_proofs);
    EXPECT_TRUE(table->admit("ip 10.0.0.9", start + 60s).ticket) << "the oldest failure is a minute old";
    EXPECT_TRUE(table->admit("ip 10.0.0.8", start + 10s).ticket) << "another peer is not shut out";
}

TEST(PeerLimits_test, APeerWithNothingOpenAndNoRecentFailureIsForgotten) {
    auto table = limits(100, 100, 3);
    {
        auto a = table->admit("ip 10.0.0.1");
        auto b = table->admit("uid 0");
        EXPECT_EQ(table->peers(), 2u);
    }
    EXPECT_EQ(table->peers(), 0u);
    {
        auto refused_later = table->admit("ip 10.0.0.2");
        refused_later.ticket->proof_failed();
    }
    EXPECT_EQ(table->peers(), 1u) << "a recent failure is remembered";
}

}  // namespace
}  // namespace plexus::daemon
