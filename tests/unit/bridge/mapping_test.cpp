#include <gtest/gtest.h>

#include "mapping.hpp"
#include "ros2_qos.hpp"

namespace plexus::bridge {
namespace {

TEST(BridgeMapping_test, AMappingHasTwoSidesAndForRos2AType) {
    const auto in = parse_mapping("/chatter=/ros/chatter:std_msgs/msg/String", "--in", true);
    EXPECT_EQ(in.from, "/chatter");
    EXPECT_EQ(in.to, "/ros/chatter");
    EXPECT_EQ(in.type, "std_msgs/msg/String");
    const auto mqtt = parse_mapping("sensors/+/temp=/mqtt/temp", "--in", false);
    EXPECT_EQ(mqtt.from, "sensors/+/temp");
    EXPECT_EQ(mqtt.to, "/mqtt/temp");
    EXPECT_THROW(parse_mapping("/chatter", "--in", true), UsageError);
    EXPECT_THROW(parse_mapping("/chatter=/ros/chatter", "--in", true), UsageError);
    EXPECT_THROW(parse_mapping("=/x:std_msgs/msg/String", "--in", true), UsageError);
    EXPECT_THROW(parse_mapping("/a=/b:", "--in", true), UsageError);
    EXPECT_THROW(require_port("no/slash", "--in"), UsageError);
    EXPECT_THROW(require_distinct_ports({"/a", "/b", "/a"}, "ros2"), UsageError);
}

TEST(BridgeMapping_test, Ros2NamesAndQos) {
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
