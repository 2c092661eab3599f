// The simulated world's message formats (tools/sim/README.md): what is read, what is refused, what
// is written.
#include <gtest/gtest.h>

#include "world_messages.hpp"

namespace plexus::sim {
namespace {

TEST(WorldMessages_test, ReadsPointsAndRefusesMalformedOnes) {
    const auto point = parse_point(Json{{"x", 0.5}, {"y", -1}});
    ASSERT_TRUE(point);
    EXPECT_DOUBLE_EQ(point.value->x, 0.5);
    EXPECT_DOUBLE_EQ(point.value->y, -1.0);
    EXPECT_TRUE(parse_point(Json{{"x", 1}, {"y", 2}, {"certainty", 0.7}}));  // extra keys are fine

    for (const Json& bad : {Json(nullptr), Json(3), Json("x"), Json::array({1, 2}), Json{{"x", 1}},
                            Json{{"x", "1"}, {"y", 2}}, Json{{"x", 1}, {"y", nullptr}}}) {
        const auto parsed = parse_point(bad);
        EXPECT_FALSE(parsed) << bad.dump();
        EXPECT_FALSE(parsed.error.empty());
    }
}

TEST(WorldMessages_test, ReadsGazeTargetsAsAnAngleOrAPoint) {
    const auto angle = parse_gaze_target(Json{{"angle", 0.3}});
    ASSERT_TRUE(angle);
    EXPECT_DOUBLE_EQ(std::get<double>(*angle.value), 0.3);
    const auto point = parse_gaze_target(Json{{"x", 1}, {"y", 1}});
    ASSERT_TRUE(point);
    EXPECT_DOUBLE_EQ(std::get<Point>(*point.value).y, 1.0);
    EXPECT_FALSE(parse_gaze_target(Json{{"angle", "left"}}));
    EXPECT_FALSE(parse_gaze_target(Json{{"a", 1}}));
}

TEST(WorldMessages_test, ReadsHandCommands) {
    EXPECT_EQ(parse_hand_command(Json{{"close", true}}).value, true);
    EXPECT_EQ(parse_hand_command(Json{{"close", false}}).value, false);
    EXPECT_FALSE(parse_hand_command(Json{{"close", 1}}));
    EXPECT_FALSE(parse_hand_command(Json("close")));
}

TEST(WorldMessages_test, ReadsDisturbancesAndRefusesOthers) {
    EXPECT_EQ(parse_disturbance(Json{{"drop", true}}).value, Disturbance::drop);
    EXPECT_EQ(parse_disturbance(Json{{"hide", true}}).value, Disturbance::hide);
    EXPECT_EQ(parse_disturbance(Json{{"person", "away"}}).value, Disturbance::person_away);
    EXPECT_EQ(parse_disturbance(Json{{"person", "back"}}).value, Disturbance::person_back);
    for (const Json& bad : {Json{{"drop", false}}, Json{{"person", "left"}}, Json{{"explode", true}},
                            Json{{"drop", true}, {"hide", true}}, Json(nullptr), Json::array()}) {
        const auto parsed = parse_disturbance(bad);
        EXPECT_FALSE(parsed) << bad.dump();
        EXPECT_FALSE(parsed.error.empty());
    }
}

TEST(WorldMessages_test, WritesTheObjectAndPersonOnlyWhileVisible) {
    WorldRules rules;
    rules.person_max_speed = 0;
    WorldModel world(1, rules);
    world.place_object({0.5, 0.0});
    world.place_person(0.1);
    const auto object = object_message(world);
    ASSERT_TRUE(object);
    EXPECT_DOUBLE_EQ((*object)["x"].get<double>(), 0.5);
    EXPECT_DOUBLE_EQ((*object)["certainty"].get<double>(), 1.0);
    const auto person = person_message(world);
    ASSERT_TRUE(person);
    EXPECT_NEAR((*person)["x"].get<double>(), std::cos(0.1), 1e-12);

    world.hide();
    world.person_away();
    EXPECT_FALSE(object_message(world));
    EXPECT_FALSE(person_message(world));
    EXPECT_EQ(proximity_message(world), (Json{{"object", nullptr}, {"person", nullptr}}));
}

TEST(WorldMessages_test, WritesTheBodyStateAndThePhase) {
    WorldModel world(1);
    EXPECT_EQ(touch_message(world), (Json{{"held", false}}));
    EXPECT_EQ(head_message(world), (Json{{"gaze", 0.0}}));
    EXPECT_EQ(arm_message(world), (Json{{"x", 0.15}, {"y", 0.0}}));
    EXPECT_EQ(hand_message(world), (Json{{"state", "open"}, {"holding", false}}));
    world.command_hand(true);
    EXPECT_EQ(hand_message(world)["state"], "closing");
    const Json phase = phase_message(world);
    EXPECT_TRUE(phase["phase"].is_string());
    EXPECT_EQ(phase["t"], 0.0);
    EXPECT_EQ(phase["deliveries"], 0);
    const Json proximity = proximity_message(world);
    EXPECT_TRUE(proximity["object"].is_number());
    EXPECT_TRUE(proximity["person"].is_number());
}

TEST(WorldMessages_test, AppliesDisturbancesToTheWorld) {
    WorldModel world(1);
    EXPECT_FALSE(apply(world, Disturbance::drop).applied);
    EXPECT_TRUE(apply(world, Disturbance::person_away).applied);
    EXPECT_FALSE(world.person());
    EXPECT_TRUE(apply(world, Disturbance::person_back).applied);
    EXPECT_TRUE(apply(world, Disturbance::hide).applied);
    EXPECT_EQ(world.object_state(), ObjectState::hidden);
}

}  // namespace
}  // namespace plexus::sim
