// The event container of an input port: per-owner entries, lifetimes checked against the time
// the caller passes (so these tests give explicit times), and no owner hiding another's event.
#include "arbitration/events.hpp"

#include <gtest/gtest.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace plexus::daemon::arbitration {
namespace {

constexpr double t0 = 1000.0;
constexpr std::uint64_t face = 1;
constexpr std::uint64_t object = 2;

std::vector<std::string> names(const std::vector<EventContainer::Entry>& entries) {
    std::vector<std::string> list;
    for (const auto& entry : entries)
        list.push_back(entry.name + "@" + std::to_string(entry.owner));
    return list;
}

TEST(EventContainer_test, SetEventIsPresentAndOthersAreNot) {
    EventContainer events;
    EXPECT_FALSE(events.has("e_face", t0));
    events.set("e_face", face, "/face/out (detector)", std::nullopt, t0);
    EXPECT_TRUE(events.has("e_face", t0));
    EXPECT_FALSE(events.has("e_object", t0));
    // No substring matching in the container either.
    EXPECT_FALSE(events.has("e_fac", t0));
    EXPECT_FALSE(events.has("e_face_seen", t0));
}

TEST(EventContainer_test, WithoutLifetimeAnEventStaysUntilUnset) {
    EventContainer events;
    events.set("e_face", face, "", std::nullopt, t0);
    EXPECT_TRUE(events.has("e_face", t0 + 1e6));
    events.unset("e_face", face);
    EXPECT_FALSE(events.has("e_face", t0));
}

TEST(EventContainer_test, ZeroOrNegativeLifetimeMeansNoExpiry) {
    EventContainer events;
    events.set("e_zero", face, "", 0.0, t0);
    events.set("e_negative", face, "", -1.0, t0);
    EXPECT_TRUE(events.has("e_zero", t0 + 1e6));
    EXPECT_TRUE(events.has("e_negative", t0 + 1e6));
}

TEST(EventContainer_test, ALifetimeEndsExactlyOnTime) {
    EventContainer events;
    // Set at 1000 with 0.5 s: live while now < 1000.5, gone from 1000.5 on.
    events.set("e_face", face, "", 0.5, t0);
    EXPECT_TRUE(events.has("e_face", t0));
    EXPECT_TRUE(events.has("e_face", t0 + 0.49));
    EXPECT_TRUE(events.has("e_face", 1000.4999999));
    EXPECT_FALSE(events.has("e_face", 1000.5));
    EXPECT_FALSE(events.has("e_face", t0 + 0.51));
}

TEST(EventContainer_test, SettingAgainRefreshesTheLifetime) {
    EventContainer events;
    events.set("e_face", face, "", 0.5, t0);
    // Refreshed at 1000.25 with 0.5 s: now lives until 1000.75, past the first expiry at 1000.5.
    events.set("e_face", face, "", 0.5, t0 + 0.25);
    EXPECT_TRUE(events.has("e_face", t0 + 0.5));
    EXPECT_TRUE(events.has("e_face", t0 + 0.74));
    EXPECT_FALSE(events.has("e_face", t0 + 0.75));
    // Still one entry: a refresh replaces, it does not add.
    EXPECT_EQ(events.entries(t0).size(), 1u);
}

TEST(EventContainer_test, SettingAgainWithoutLifetimeMakesItPermanentAndBack) {
    EventContainer events;
    events.set("e_face", face, "", 0.5, t0);
    events.set("e_face", face, "", std::nullopt, t0);
    EXPECT_TRUE(events.has("e_face", t0 + 100));
    events.set("e_face", face, "", 0.5, t0 + 100);
    EXPECT_FALSE(events.has("e_face", t0 + 100.5));
}

TEST(EventContainer_test, SettingAnExpiredEntryAgainRevivesIt) {
    EventContainer events;
    events.set("e_face", face, "", 0.5, t0);
    EXPECT_FALSE(events.has("e_face", t0 + 1));
    events.set("e_face", face, "", 0.5, t0 + 1);
    EXPECT_TRUE(events.has("e_face", t0 + 1.25));
}

TEST(EventContainer_test, UnsetRemovesOnlyTheCallersOwnEntry) {
    EventContainer events;
    events.set("e_target", face, "/face/out", std::nullopt, t0);
    events.set("e_target", object, "/object/out", std::nullopt, t0);
    events.unset("e_target", face);
    // The object monitor's entry keeps the event alive.
    EXPECT_TRUE(events.has("e_target", t0));
    ASSERT_EQ(events.entries(t0).size(), 1u);
    EXPECT_EQ(events.entries(t0)[0].owner, object);
    EXPECT_EQ(events.entries(t0)[0].owner_label, "/object/out");
    events.unset("e_target", object);
    EXPECT_FALSE(events.has("e_target", t0));
}

TEST(EventContainer_test, UnsetOfSomethingNotSetChangesNothing) {
    EventContainer events;
    events.set("e_target", face, "", std::nullopt, t0);
    events.unset("e_target", object);  // another owner's name
    events.unset("e_other", face);     // a name the owner never set
    EXPECT_TRUE(events.has("e_target", t0));
}

TEST(EventContainer_test, RemoveOwnerTakesAllItsEntriesAndOnlyThose) {
    EventContainer events;
    events.set("e_a", face, "", std::nullopt, t0);
    events.set("e_b", face, "", 5.0, t0);
    events.set("e_a", object, "", std::nullopt, t0);
    events.set("e_c", object, "", std::nullopt, t0);
    events.remove_owner(face);
    EXPECT_TRUE(events.has("e_a", t0)) << "the object monitor's e_a stays";
    EXPECT_FALSE(events.has("e_b", t0));
    EXPECT_TRUE(events.has("e_c", t0));
    EXPECT_EQ(names(events.entries(t0)), (std::vector<std::string>{"e_a@2", "e_c@2"}));
}

TEST(EventContainer_test, AnExpiredEntryOfOneOwnerDoesNotHideAnothersLiveEntry) {
    EventContainer events;
    // Face's entry comes first and expires; object's, later in the list, has no lifetime.
    events.set("e_target", face, "", 0.5, t0);
    events.set("e_target", object, "", std::nullopt, t0);
    EXPECT_TRUE(events.has("e_target", t0 + 1));
    // Once the object unsets its own, only face's expired entry is left: the event is gone.
    events.unset("e_target", object);
    EXPECT_FALSE(events.has("e_target", t0 + 1));
}

TEST(EventContainer_test, TheLongestLivedOwnerDecidesWhenTheEventEnds) {
    EventContainer events;
    events.set("e_target", face, "", 0.5, t0);
    events.set("e_target", object, "", 2.0, t0);
    EXPECT_TRUE(events.has("e_target", t0 + 1.0));
    EXPECT_TRUE(events.has("e_target", t0 + 1.99));
    EXPECT_FALSE(events.has("e_target", t0 + 2.0));
}

TEST(EventContainer_test, EntriesListsLiveOnesInOrderAndForgetsExpiredOnes) {
    EventContainer events;
    events.set("e_short", face, "/face/out (a)", 0.5, t0);
    events.set("e_long", object, "/object/out (b)", std::nullopt, t0);
    events.set("e_mid", face, "/face/out (a)", 1.0, t0);
    EXPECT_EQ(names(events.entries(t0)), (std::vector<std::string>{"e_short@1", "e_long@2", "e_mid@1"}));
    const auto& live = events.entries(t0 + 0.75);
    EXPECT_EQ(names(live), (std::vector<std::string>{"e_long@2", "e_mid@1"}));
    ASSERT_TRUE(live[1].expires.has_value());
    EXPECT_DOUBLE_EQ(*live[1].expires, t0 + 1.0);
    EXPECT_FALSE(live[0].expires.has_value());
    // Forgotten, not just hidden: asking about an earlier time does not bring it back.
    EXPECT_FALSE(events.has("e_short", t0));
}

TEST(EventContainer_test, EntriesKeepTheOwnersLabel) {
    EventContainer events;
    events.set("e_face", face, "/face/out (certainty)", std::nullopt, t0);
    ASSERT_EQ(events.entries(t0).size(), 1u);
    EXPECT_EQ(events.entries(t0)[0].owner_label, "/face/out (certainty)");
    EXPECT_EQ(events.entries(t0)[0].name, "e_face");
}

TEST(EventContainer_test, ExpiredEntriesDoNotPileUpWhenScriptsKeepSettingNewNames) {
    EventContainer events;
    // A script that sets a fresh name every 0.1 s with a 0.5 s lifetime: only about five live.
    for (int i = 0; i < 1000; ++i)
        events.set("e_" + std::to_string(i), face, "", 0.5, t0 + 0.1 * i);
    EXPECT_LE(events.entries(t0 + 0.1 * 999).size(), 6u);
}

}  // namespace
}  // namespace plexus::daemon::arbitration
