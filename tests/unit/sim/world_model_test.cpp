// The simulated world's rules (tools/sim/README.md), stepped by hand with a fixed dt.
#include <cmath>

#include <gtest/gtest.h>

#include "world_model.hpp"

namespace plexus::sim {
namespace {

constexpr double dt = 0.02;

/// Steps the world for `seconds` of sim time.
void run(WorldModel& world, double seconds) {
    const int steps = static_cast<int>(std::lround(seconds / dt));
    for (int i = 0; i < steps; ++i)
        world.step(dt);
}

/// Rules with a person who stands still, so that distances to her are exact.
WorldRules still_person() {
    WorldRules rules;
    rules.person_max_speed = 0;
    return rules;
}

/// A world whose hand holds the object at `at` (the arm went there and the hand closed).
WorldModel holding_at(Point at) {
    WorldModel world(1, still_person());
    world.place_object(at);
    world.set_arm_target(at);
    run(world, 2.0);
    world.command_hand(true);
    run(world, 0.4);
    EXPECT_TRUE(world.holding());
    return world;
}

TEST(WorldModel_test, StartsWithHandHomeHeadAheadAndObjectOnTheTable) {
    WorldModel world(7);
    EXPECT_DOUBLE_EQ(world.hand().x, 0.15);
    EXPECT_DOUBLE_EQ(world.hand().y, 0.0);
    EXPECT_DOUBLE_EQ(world.gaze(), 0.0);
    EXPECT_EQ(world.hand_state(), HandState::open);
    ASSERT_TRUE(world.object());
    EXPECT_GE(world.object()->x, 0.3);
    EXPECT_LE(world.object()->x, 0.6);
    EXPECT_GE(world.object()->y, -0.4);
    EXPECT_LE(world.object()->y, 0.4);
    ASSERT_TRUE(world.person());
    EXPECT_LE(std::abs(world.person_angle()), 1.2);
    EXPECT_NEAR(std::hypot(world.person()->x, world.person()->y), 1.0, 1e-12);
}

TEST(WorldModel_test, IsDeterministicForASeed) {
    WorldModel a(42);
    WorldModel b(42);
    WorldModel c(43);
    run(a, 20);
    run(b, 20);
    run(c, 20);
    EXPECT_EQ(a.object()->x, b.object()->x);
    EXPECT_EQ(a.person_angle(), b.person_angle());
    EXPECT_NE(a.person_angle(), c.person_angle());
}

TEST(WorldModel_test, PersonWalksSlowlyWithinTheBounds) {
    WorldModel world(3);
    double before = world.person_angle();
    for (int i = 0; i < 30000; ++i) {  // 600 s: long enough to meet the bounds
        world.step(dt);
        EXPECT_LE(std::abs(world.person_angle()), 1.2);
        EXPECT_LE(std::abs(world.person_angle() - before), 0.15 * dt + 1e-12);
        before = world.person_angle();
    }
}

TEST(WorldModel_test, GraspsWhenTheHandClosesWithinFourCentimetres) {
    WorldModel world(1, still_person());
    world.place_object({0.45, 0.1});
    world.set_arm_target({0.45 + 0.039, 0.1});
    run(world, 2.0);
    world.command_hand(true);
    EXPECT_EQ(world.hand_state(), HandState::closing);
    run(world, 0.28);
    EXPECT_FALSE(world.holding());  // the transition takes 0.3 s
    run(world, 0.04);
    EXPECT_EQ(world.hand_state(), HandState::closed);
    EXPECT_TRUE(world.holding());
    EXPECT_TRUE(world.object());
    EXPECT_DOUBLE_EQ(world.object()->x, world.hand().x);

    // The object moves with the hand.
    world.set_arm_target({0.2, 0.0});
    run(world, 2.0);
    EXPECT_NEAR(world.object()->x, 0.2, 1e-12);
}

TEST(WorldModel_test, ClosesEmptyAwayFromTheObject) {
    WorldModel world(1, still_person());
    world.place_object({0.45, 0.1});
    world.set_arm_target({0.45 + 0.045, 0.1});
    run(world, 2.0);
    world.command_hand(true);
    run(world, 0.4);
    EXPECT_EQ(world.hand_state(), HandState::closed);
    EXPECT_FALSE(world.holding());
    EXPECT_EQ(world.object_state(), ObjectState::on_table);
}

TEST(WorldModel_test, RepeatedHandCommandsAreIgnoredAndTheLatestWishIsKept) {
    WorldModel world(1, still_person());
    world.command_hand(true);
    run(world, 0.1);
    world.command_hand(true);  // the same direction: the transition is not restarted
    run(world, 0.22);
    EXPECT_EQ(world.hand_state(), HandState::closed);

    world.command_hand(false);
    EXPECT_EQ(world.hand_state(), HandState::opening);
    world.command_hand(true);  // changes the wish during the transition: it completes, then turns back
    run(world, 0.3);
    EXPECT_EQ(world.hand_state(), HandState::closing);
    run(world, 0.3);
    EXPECT_EQ(world.hand_state(), HandState::closed);
}

TEST(WorldModel_test, ReleaseNearThePersonCountsADeliveryAndANewObjectAppearsASecondLater) {
    WorldModel world = holding_at({0.5, 0.0});
    world.place_person(0.0);
    world.set_arm_target({0.75, 0.0});  // 0.25 m from the person at (1, 0)
    run(world, 1.0);
    world.command_hand(false);
    run(world, 0.3);
    EXPECT_EQ(world.hand_state(), HandState::open);
    EXPECT_EQ(world.deliveries(), 1);
    EXPECT_EQ(world.object_state(), ObjectState::absent);
    EXPECT_FALSE(world.object());
    EXPECT_FALSE(world.hand_to_object());
    EXPECT_EQ(world.phase(), Phase::release);

    run(world, 0.96);
    EXPECT_EQ(world.object_state(), ObjectState::absent);
    run(world, 0.06);
    EXPECT_EQ(world.object_state(), ObjectState::on_table);
    ASSERT_TRUE(world.object());
    EXPECT_GE(world.object()->x, 0.3);
    EXPECT_LE(world.object()->x, 0.6);
    EXPECT_EQ(world.phase(), Phase::search_object);
}

TEST(WorldModel_test, ReleaseFarFromThePersonPutsTheObjectOnTheTableUnderTheHand) {
    WorldModel world = holding_at({0.5, 0.0});
    world.place_person(1.0);
    world.set_arm_target({0.0, 0.7});  // off the table: the object lands at its nearest point
    run(world, 2.0);
    world.command_hand(false);
    run(world, 0.32);
    EXPECT_EQ(world.deliveries(), 0);
    EXPECT_EQ(world.object_state(), ObjectState::on_table);
    EXPECT_DOUBLE_EQ(world.object()->x, 0.3);
    EXPECT_DOUBLE_EQ(world.object()->y, 0.4);
}

TEST(WorldModel_test, ReleaseWhileThePersonIsAwayIsNoDelivery) {
    WorldModel world = holding_at({0.5, 0.0});
    world.place_person(0.0);
    world.set_arm_target({0.75, 0.0});
    run(world, 1.0);
    EXPECT_TRUE(world.person_away().applied);
    world.command_hand(false);
    run(world, 0.32);
    EXPECT_EQ(world.deliveries(), 0);
    EXPECT_EQ(world.object_state(), ObjectState::on_table);
    EXPECT_DOUBLE_EQ(world.object()->x, 0.6);
}

TEST(WorldModel_test, DropPutsAHeldObjectOnTheTableNearTheHand) {
    WorldModel world = holding_at({0.45, 0.0});
    const Outcome outcome = world.drop();
    EXPECT_TRUE(outcome.applied);
    EXPECT_EQ(world.object_state(), ObjectState::on_table);
    EXPECT_FALSE(world.holding());
    EXPECT_LE(distance(*world.object(), world.hand()), 0.1 + 1e-12);
    EXPECT_EQ(world.hand_state(), HandState::closed);  // the hand stays closed, empty

    EXPECT_FALSE(world.drop().applied);  // nothing held: ignored
}

TEST(WorldModel_test, DropClampsIntoTheTable) {
    WorldModel world = holding_at({0.3, 0.4});
    EXPECT_TRUE(world.drop().applied);
    EXPECT_GE(world.object()->x, 0.3);
    EXPECT_LE(world.object()->y, 0.4);
}

TEST(WorldModel_test, HideMakesTheObjectInvisibleForThreeSecondsThenMovesIt) {
    WorldModel world(5, still_person());
    world.place_object({0.5, 0.0});
    EXPECT_TRUE(world.object_visible());
    EXPECT_TRUE(world.hide().applied);
    EXPECT_EQ(world.object_state(), ObjectState::hidden);
    EXPECT_FALSE(world.object_visible());
    EXPECT_FALSE(world.object());
    EXPECT_FALSE(world.hand_to_object());
    EXPECT_FALSE(world.hide().applied);  // already hidden

    run(world, 2.96);
    EXPECT_EQ(world.object_state(), ObjectState::hidden);
    run(world, 0.06);
    EXPECT_EQ(world.object_state(), ObjectState::on_table);
    EXPECT_NE(world.object()->x, 0.5);
}

TEST(WorldModel_test, HideIsIgnoredWhileHeld) {
    WorldModel world = holding_at({0.45, 0.0});
    const Outcome outcome = world.hide();
    EXPECT_FALSE(outcome.applied);
    EXPECT_FALSE(outcome.reason.empty());
    EXPECT_TRUE(world.holding());
}

TEST(WorldModel_test, PersonGoesAwayAndComesBackAtARandomAngle) {
    WorldModel world(9);
    EXPECT_TRUE(world.person_away().applied);
    EXPECT_FALSE(world.person());
    EXPECT_FALSE(world.person_visible());
    EXPECT_FALSE(world.hand_to_person());
    EXPECT_FALSE(world.person_away().applied);

    EXPECT_TRUE(world.person_back().applied);
    ASSERT_TRUE(world.person());
    EXPECT_LE(std::abs(world.person_angle()), 1.2);
    EXPECT_TRUE(world.hand_to_person());
    EXPECT_FALSE(world.person_back().applied);
}

TEST(WorldModel_test, SeesWithinThreeTenthsOfARadianOfTheGaze) {
    WorldModel world(1, still_person());
    world.place_object({0.5 * std::cos(0.29), 0.5 * std::sin(0.29)});
    EXPECT_TRUE(world.object_visible());
    EXPECT_NEAR(*world.object_certainty(), 1 - 0.5 * 0.29 / 0.3, 1e-9);
    world.place_object({0.5 * std::cos(-0.31), 0.5 * std::sin(-0.31)});
    EXPECT_FALSE(world.object_visible());
    EXPECT_FALSE(world.object_certainty());
    world.place_object({0.5, 0.0});
    EXPECT_DOUBLE_EQ(*world.object_certainty(), 1.0);

    world.place_person(0.25);
    EXPECT_TRUE(world.person_visible());
    world.place_person(0.35);
    EXPECT_FALSE(world.person_visible());

    // The head turns at 2 rad/s toward the target; then the person is in view and the object not.
    world.place_person(0.9);
    EXPECT_FALSE(world.person_visible());
    world.set_gaze_target(0.7);
    run(world, 0.2);
    EXPECT_NEAR(world.gaze(), 0.4, 1e-9);
    run(world, 0.5);
    EXPECT_NEAR(world.gaze(), 0.7, 1e-12);
    EXPECT_TRUE(world.person_visible());
    EXPECT_FALSE(world.object_visible());
}

TEST(WorldModel_test, ClampsGazeAndArmTargets) {
    WorldModel world(1);
    world.set_gaze_target(3.0);
    EXPECT_DOUBLE_EQ(world.gaze_target(), 1.5);
    world.set_gaze_target(Point{0.0, -2.0});
    EXPECT_DOUBLE_EQ(world.gaze_target(), -1.5);
    world.set_gaze_target(Point{1.0, 1.0});
    EXPECT_NEAR(world.gaze_target(), std::atan2(1.0, 1.0), 1e-12);

    world.set_arm_target({3.0, 4.0});
    EXPECT_NEAR(world.arm_target().x, 0.45, 1e-12);
    EXPECT_NEAR(world.arm_target().y, 0.6, 1e-12);
    world.set_arm_target({0.2, 0.1});  // within reach: as given
    EXPECT_DOUBLE_EQ(world.arm_target().x, 0.2);
}

TEST(WorldModel_test, MovesTheHandInAStraightLineAtHalfAMetrePerSecond) {
    WorldModel world(1);
    world.set_arm_target({0.65, 0.0});
    run(world, 0.4);
    EXPECT_NEAR(world.hand().x, 0.35, 1e-9);
    EXPECT_NEAR(world.hand().y, 0.0, 1e-12);
    run(world, 0.62);  // 0.5 m take 1 s
    EXPECT_DOUBLE_EQ(world.hand().x, 0.65);
}

TEST(WorldModel_test, JudgesSearchObjectThenReachThenGrasp) {
    WorldModel world(1, still_person());
    world.place_object({0.5, 0.35});  // 0.61 rad: out of view
    world.set_arm_target({0.5, 0.35});
    EXPECT_EQ(world.phase(), Phase::search_object);  // the arm aims at it, but it is not seen

    world.set_gaze_target(Point{0.5, 0.35});
    run(world, 0.5);
    EXPECT_TRUE(world.object_visible());
    EXPECT_EQ(world.phase(), Phase::reach);
    world.set_arm_target({0.5, 0.35 - 0.11});
    EXPECT_EQ(world.phase(), Phase::search_object);  // seen, but the arm aims 0.11 m off
    world.set_arm_target({0.5, 0.35 - 0.09});
    EXPECT_EQ(world.phase(), Phase::reach);

    world.set_arm_target({0.5, 0.35});
    run(world, 2.0);
    EXPECT_EQ(world.phase(), Phase::reach);  // there, hand open
    world.command_hand(true);
    EXPECT_EQ(world.phase(), Phase::grasp);
    run(world, 0.32);
    EXPECT_TRUE(world.holding());
}

TEST(WorldModel_test, JudgesGraspAlsoWhenClosedEmptyAtTheObjectWithoutSeeingIt) {
    WorldModel world(1, still_person());
    world.place_object({0.5, 0.35});
    world.set_arm_target({0.5, 0.35});
    run(world, 2.0);
    world.command_hand(true);
    EXPECT_FALSE(world.object_visible());
    EXPECT_EQ(world.phase(), Phase::grasp);
}

TEST(WorldModel_test, JudgesSearchPersonThenApproachThenRelease) {
    WorldModel world = holding_at({0.5, 0.0});
    world.place_person(0.8);
    EXPECT_EQ(world.phase(), Phase::search_person);

    const Point reachable{0.75 * std::cos(0.8), 0.75 * std::sin(0.8)};
    world.set_arm_target({reachable.x, reachable.y - 0.14});
    EXPECT_EQ(world.phase(), Phase::approach);
    world.set_arm_target({reachable.x, reachable.y - 0.16});
    EXPECT_EQ(world.phase(), Phase::search_person);
    world.set_arm_target({reachable.x * 2, reachable.y * 2});  // clamped onto the reachable point
    EXPECT_EQ(world.phase(), Phase::approach);

    world.person_away();
    EXPECT_EQ(world.phase(), Phase::search_person);
    world.place_person(0.8);

    run(world, 2.0);
    world.command_hand(false);
    EXPECT_EQ(world.phase(), Phase::release);
    run(world, 0.32);
    EXPECT_EQ(world.deliveries(), 1);
    EXPECT_EQ(world.phase(), Phase::release);  // delivered, no new object yet
    run(world, 1.0);
    EXPECT_EQ(world.phase(), Phase::search_object);
}

}  // namespace
}  // namespace plexus::sim
