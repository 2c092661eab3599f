// The ROS 2 types' tables against what idlc generated, and the converter both ways on each type.
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "geometry_msgs/msg/Twist.h"
#include "ros2_convert.hpp"
#include "ros2_types.hpp"
#include "sensor_msgs/msg/Image.h"
#include "sensor_msgs/msg/Imu.h"
#include "sensor_msgs/msg/JointState.h"
#include "sensor_msgs/msg/PointCloud2.h"

namespace plexus::bridge::ros2 {
namespace {

TEST(Ros2Types_test, EveryTypeHasRos2sWireNameAndTheSizeOfItsCStruct) {
    const auto names = type_names();
    EXPECT_EQ(names.size(), 20u);  // the documented set, with Time and PointField they are made of
    for (const auto& name : names) {
        const auto* type = find_type(name);
        ASSERT_NE(type, nullptr) << name;
        EXPECT_EQ(type->layout->size, type->descriptor->m_size) << name;
        EXPECT_STREQ(type->descriptor->m_typename, type->dds_name.c_str()) << name;
        const auto slash = name.find('/');
        const auto last = name.rfind('/');
        EXPECT_EQ(type->dds_name, name.substr(0, slash) + "::msg::dds_::" + name.substr(last + 1) + "_");
    }
    EXPECT_EQ(find_type("std_msgs/String"), find_type("std_msgs/msg/String"));
    EXPECT_EQ(find_type("nav_msgs/msg/Odometry"), nullptr);
}

/// Fills a sample of `type` from `value` and reads it back.
Value round_trip(const std::string& type_name, const Value& value) {
    const auto* type = find_type(type_name);
    EXPECT_NE(type, nullptr);
    std::vector<char> sample(type->layout->size);
    SampleBuilder builder;
    const auto error = builder.fill(value, *type->layout, sample.data());
    EXPECT_EQ(error, "") << type_name;
    return to_value(sample.data(), *type->layout);
}

TEST(Ros2Convert_test, EachTypeComesBackAsItWentIn) {
    const Value header{{"stamp", {{"sec", -5}, {"nanosec", 7}}}, {"frame_id", "base_link"}};
    const Value vector{{"x", 1.5}, {"y", -2.0}, {"z", 0.25}};
    const Value quaternion{{"x", 0.0}, {"y", 0.0}, {"z", 0.7071}, {"w", 0.7071}};
    const std::vector<std::pair<std::string, Value>> cases{
        {"std_msgs/msg/String", {{"data", "héllo"}}},
        {"std_msgs/msg/Bool", {{"data", true}}},
        {"std_msgs/msg/Int32", {{"data", -2147483648}}},
        {"std_msgs/msg/Int64", {{"data", 9007199254740993}}},
        {"std_msgs/msg/Float32", {{"data", 0.5}}},
        {"std_msgs/msg/Float64", {{"data", 1e-300}}},
        {"std_msgs/msg/Header", header},
        {"geometry_msgs/msg/Vector3", vector},
        {"geometry_msgs/msg/Point", vector},
        {"geometry_msgs/msg/Quaternion", quaternion},
        {"geometry_msgs/msg/Twist", {{"linear", vector}, {"angular", vector}}},
        {"geometry_msgs/msg/Pose", {{"position", vector}, {"orientation", quaternion}}},
        {"geometry_msgs/msg/PoseStamped",
         {{"header", header}, {"pose", {{"position", vector}, {"orientation", quaternion}}}}},
        {"sensor_msgs/msg/Image",
         {{"header", header},
          {"height", 2},
          {"width", 3},
          {"encoding", "mono8"},
          {"is_bigendian", 0},
          {"step", 3},
          {"data", Value::binary({1, 2, 3, 4, 5, 255})}}},
        {"sensor_msgs/msg/PointField", {{"name", "x"}, {"offset", 0}, {"datatype", 7}, {"count", 1}}},
        {"sensor_msgs/msg/PointCloud2",
         {{"header", header},
          {"height", 1},
          {"width", 1},
          {"fields",
           {{{"name", "x"}, {"offset", 0}, {"datatype", 7}, {"count", 1}},
            {{"name", "y"}, {"offset", 4}, {"datatype", 7}, {"count", 1}}}},
          {"is_bigendian", false},
          {"point_step", 8},
          {"row_step", 8},
          {"data", Value::binary({0, 0, 128, 63, 0, 0, 0, 64})},
          {"is_dense", true}}},
        {"sensor_msgs/msg/LaserScan",
         {{"header", header},
          {"angle_min", -1.5},
          {"angle_max", 1.5},
          {"angle_increment", 0.5},
          {"time_increment", 0.0},
          {"scan_time", 0.125},
          {"range_min", 0.25},
          {"range_max", 8.0},
          {"ranges", {1.0, 2.5, 8.0}},
          {"intensities", Value::array()}}},
        {"sensor_msgs/msg/Imu",
         {{"header", header},
          {"orientation", quaternion},
          {"orientation_covariance", {1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0}},
          {"angular_velocity", vector},
          {"angular_velocity_covariance", {0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0}},
          {"linear_acceleration", vector},
          {"linear_acceleration_covariance", {-1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0}}}},
        {"sensor_msgs/msg/JointState",
         {{"header", header},
          {"name", {"shoulder", "elbow"}},
          {"position", {0.5, -0.5}},
          {"velocity", {0.0, 0.25}},
          {"effort", Value::array()}}},
        {"builtin_interfaces/msg/Time", {{"sec", 1}, {"nanosec", 999999999}}},
    };
    for (const auto& [type, value] : cases)
        EXPECT_EQ(round_trip(type, value), value) << type;
}

TEST(Ros2Convert_test, TheCStructHoldsWhatTheMapSaid) {
    const auto* twist = find_type("geometry_msgs/msg/Twist");
    geometry_msgs_msg_dds__Twist_ sample;
    SampleBuilder builder;
    ASSERT_EQ(builder.fill({{"linear", {{"x", 0.5}}}, {"angular", {{"z", -1}}}}, *twist->layout, &sample),
              "");
    EXPECT_EQ(sample.linear.x, 0.5);
    EXPECT_EQ(sample.linear.y, 0.0);
    EXPECT_EQ(sample.angular.z, -1.0);

    const auto* image = find_type("sensor_msgs/msg/Image");
    const Value message{{"encoding", "rgb8"}, {"data", Value::binary(std::vector<std::uint8_t>(1000, 9))}};
    const auto& blob = message["data"];
    sensor_msgs_msg_dds__Image_ picture;
    ASSERT_EQ(builder.fill(message, *image->layout, &picture), "");
    EXPECT_STREQ(picture.encoding, "rgb8");
    EXPECT_STREQ(picture.header.frame_id, "") << "an absent string is empty, never null";
    EXPECT_EQ(picture.data._length, 1000u);
    EXPECT_EQ(picture.data._buffer, blob.get_binary().data()) << "a blob is not copied on its way out";

    const auto* joints = find_type("sensor_msgs/msg/JointState");
    sensor_msgs_msg_dds__JointState_ state;
    ASSERT_EQ(builder.fill({{"name", {"a", "b"}}, {"position", {1, 2}}}, *joints->layout, &state), "");
    ASSERT_EQ(state.name._length, 2u);
    EXPECT_STREQ(state.name._buffer[1], "b");
    EXPECT_EQ(state.position._buffer[1], 2.0);
}

TEST(Ros2Convert_test, DefaultsAreRos2s) {
    const auto value = round_trip("geometry_msgs/msg/Quaternion", Value::object());
    EXPECT_EQ(value, (Value{{"x", 0.0}, {"y", 0.0}, {"z", 0.0}, {"w", 1.0}})) << "the identity rotation";
    const auto header = round_trip("std_msgs/msg/Header", Value::object());
    EXPECT_EQ(header["frame_id"], "");
}

TEST(Ros2Convert_test, ABlobMayAlsoBeAListOfBytes) {
    const auto value = round_trip("sensor_msgs/msg/Image", {{"data", {1, 2, 3}}});
    EXPECT_EQ(value["data"], Value::binary({1, 2, 3}));
}

TEST(Ros2Convert_test, WhatDoesNotFitIsAnErrorNamingTheField) {
    const auto error_of = [](const std::string& type_name, const Value& value) {
        const auto* type = find_type(type_name);
        std::vector<char> sample(type->layout->size);
        SampleBuilder builder;
        return builder.fill(value, *type->layout, sample.data());
    };
    EXPECT_EQ(error_of("geometry_msgs/msg/Twist", {{"linear", {{"x", "fast"}}}}),
              "linear.x: expected a number, not a text");
    EXPECT_EQ(error_of("geometry_msgs/msg/Twist", {{"linear", {{"w", 1}}}}),
              "linear.w: geometry_msgs/msg/Vector3 has no such field");
    EXPECT_EQ(error_of("geometry_msgs/msg/Twist", {{"linear", 3}}), "linear: expected a map, not a number");
    EXPECT_EQ(error_of("geometry_msgs/msg/Twist", "text"),
              "geometry_msgs/msg/Twist: expected a map, not a text");
    EXPECT_EQ(error_of("std_msgs/msg/Int32", {{"data", 2147483648}}), "data: 2147483648 does not fit");
    EXPECT_EQ(error_of("std_msgs/msg/Int32", {{"data", 1.5}}), "data: expected a whole number, not a number");
    EXPECT_EQ(error_of("sensor_msgs/msg/Image", {{"width", -1}}), "width: -1 does not fit");
    EXPECT_EQ(error_of("sensor_msgs/msg/Image", {{"data", {1, 256}}}), "data[1]: 256 does not fit");
    EXPECT_EQ(error_of("sensor_msgs/msg/Imu", {{"orientation_covariance", {1, 2}}}),
              "orientation_covariance: expected a list of 9 numbers, not a list");
    EXPECT_EQ(error_of("sensor_msgs/msg/JointState", {{"name", {"a", 1}}}),
              "name[1]: expected a text, not a number");
    EXPECT_EQ(error_of("sensor_msgs/msg/PointCloud2", {{"fields", {{{"nam", "x"}}}}}),
              "fields[0].nam: sensor_msgs/msg/PointField has no such field");
}

}  // namespace
}  // namespace plexus::bridge::ros2
