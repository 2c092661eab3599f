// The consistency check's limits: exhaustive up to 16 events per pair, a possible overlap past it.
#include <gtest/gtest.h>

#include "arbitration/consistency.hpp"

namespace plexus::daemon::arbitration {
namespace {

Constraint parsed(const std::string& text) {
    auto constraint = Constraint::parse(text);
    EXPECT_TRUE(constraint) << constraint.error().message;
    return *constraint;
}

std::string conjunction(int events) {
    std::string text = "e1";
    for (int k = 2; k <= events; ++k)
        text += " and e" + std::to_string(k);
    return text;
}

TEST(Consistency_test, FindsTheOnlyWitnessEvenWhenItIsTheLastAssignmentOf16Events) {
    // Every one of the 16 events must be present: the last of the 2^16 assignments tried.
    const Constraint all = parsed(conjunction(16));
    const std::vector<Rule> rules{{"/a", &all, false}, {"/b", nullptr, false}};
    const auto overlaps = find_overlaps(rules);
    ASSERT_EQ(overlaps.size(), 1u);
    ASSERT_TRUE(overlaps[0].witness.has_value());
    EXPECT_EQ(overlaps[0].witness->size(), 16u);
    for (const auto& [event, present] : *overlaps[0].witness)
        EXPECT_TRUE(present) << event;
}

TEST(Consistency_test, PastSixteenEventsAPairIsReportedWithoutAWitness) {
    const Constraint many = parsed(conjunction(17));
    const Constraint never = parsed("false");
    const std::vector<Rule> rules{{"/a", &many, false}, {"/b", &never, false}};
    // Even a pair that cannot overlap is reported as possible: the check does not guess.
    const auto overlaps = find_overlaps(rules);
    ASSERT_EQ(overlaps.size(), 1u);
    EXPECT_FALSE(overlaps[0].witness.has_value());
}

TEST(Consistency_test, ExclusiveConstraintsDoNotOverlapAndTwoStimulatedConnectionsAreNotCompared) {
    const Constraint first = parsed("e_a and not e_b");
    const Constraint second = parsed("e_b");
    EXPECT_TRUE(find_overlaps({{"/a", &first, false}, {"/b", &second, false}}).empty());
    EXPECT_TRUE(find_overlaps({{"/a", nullptr, true}, {"/b", nullptr, true}}).empty());
    EXPECT_EQ(find_overlaps({{"/a", nullptr, true}, {"/b", nullptr, false}}).size(), 1u);
}

}  // namespace
}  // namespace plexus::daemon::arbitration
