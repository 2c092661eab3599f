// ROS 2's topic names on DDS and the QoS of a mapping, checked at start.
#include <gtest/gtest.h>

#include "mapping.hpp"
#include "ros2_qos.hpp"

namespace plexus::bridge {
namespace {

TEST(Ros2Qos_test, TopicNamesAndQos) {
    EXPECT_EQ(ros2::dds_topic_name("/chatter", "x"), "rt/chatter");
    EXPECT_EQ(ros2::dds_topic_name("robot/cmd_vel", "x"), "rt/robot/cmd_vel");
    EXPECT_THROW(ros2::dds_topic_name("/bad topic", "x"), UsageError);
    EXPECT_THROW(ros2::dds_topic_name("/1st", "x"), UsageError);
    EXPECT_THROW(ros2::dds_topic_name("/", "x"), UsageError);
    const auto qos = ros2::parse_qos("best-effort,transient-local,depth=5", {}, "x");
    EXPECT_FALSE(qos.reliable);
    EXPECT_TRUE(qos.transient_local);
    EXPECT_EQ(qos.depth, 5);
    const ros2::Qos defaults;
    EXPECT_TRUE(defaults.reliable);
    EXPECT_FALSE(defaults.transient_local);
    EXPECT_EQ(defaults.depth, 10);
    EXPECT_THROW(ros2::parse_qos("fast", {}, "x"), UsageError);
    EXPECT_THROW(ros2::parse_qos("depth=0", {}, "x"), UsageError);
}

}  // namespace
}  // namespace plexus::bridge
