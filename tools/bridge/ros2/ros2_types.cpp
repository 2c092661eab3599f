#include "ros2_types.hpp"

#include <algorithm>

#include "builtin_interfaces/msg/Time.h"
#include "geometry_msgs/msg/Point.h"
#include "geometry_msgs/msg/Pose.h"
#include "geometry_msgs/msg/PoseStamped.h"
#include "geometry_msgs/msg/Quaternion.h"
#include "geometry_msgs/msg/Twist.h"
#include "geometry_msgs/msg/Vector3.h"
#include "sensor_msgs/msg/Image.h"
#include "sensor_msgs/msg/Imu.h"
#include "sensor_msgs/msg/JointState.h"
#include "sensor_msgs/msg/LaserScan.h"
#include "sensor_msgs/msg/PointCloud2.h"
#include "sensor_msgs/msg/PointField.h"
#include "std_msgs/msg/Bool.h"
#include "std_msgs/msg/Float32.h"
#include "std_msgs/msg/Float64.h"
#include "std_msgs/msg/Header.h"
#include "std_msgs/msg/Int32.h"
#include "std_msgs/msg/Int64.h"
#include "std_msgs/msg/String.h"

namespace plexus::bridge::ros2 {

namespace {

// Layouts of the C structs idlc generated, in the order they nest. Written after the IDL in
// tools/bridge/ros2/idl; ros2_types_test checks each against the descriptor's size.
const StructLayout builtin_interfaces_Time{
    "builtin_interfaces/msg/Time",
    sizeof(builtin_interfaces_msg_dds__Time_),
    {
        {"sec", FieldKind::int32, offsetof(builtin_interfaces_msg_dds__Time_, sec)},
        {"nanosec", FieldKind::uint32, offsetof(builtin_interfaces_msg_dds__Time_, nanosec)},
    }};
const StructLayout geometry_msgs_Point{
    "geometry_msgs/msg/Point",
    sizeof(geometry_msgs_msg_dds__Point_),
    {
        {"x", FieldKind::float64, offsetof(geometry_msgs_msg_dds__Point_, x)},
        {"y", FieldKind::float64, offsetof(geometry_msgs_msg_dds__Point_, y)},
        {"z", FieldKind::float64, offsetof(geometry_msgs_msg_dds__Point_, z)},
    }};
const StructLayout geometry_msgs_Quaternion{
    "geometry_msgs/msg/Quaternion",
    sizeof(geometry_msgs_msg_dds__Quaternion_),
    {
        {"x", FieldKind::float64, offsetof(geometry_msgs_msg_dds__Quaternion_, x)},
        {"y", FieldKind::float64, offsetof(geometry_msgs_msg_dds__Quaternion_, y)},
        {"z", FieldKind::float64, offsetof(geometry_msgs_msg_dds__Quaternion_, z)},
        {"w", FieldKind::float64, offsetof(geometry_msgs_msg_dds__Quaternion_, w), nullptr, 0, 1.0},
    }};
const StructLayout geometry_msgs_Pose{
    "geometry_msgs/msg/Pose",
    sizeof(geometry_msgs_msg_dds__Pose_),
    {
        {"position", FieldKind::structure, offsetof(geometry_msgs_msg_dds__Pose_, position),
         &geometry_msgs_Point},
        {"orientation", FieldKind::structure, offsetof(geometry_msgs_msg_dds__Pose_, orientation),
         &geometry_msgs_Quaternion},
    }};
const StructLayout std_msgs_Header{
    "std_msgs/msg/Header",
    sizeof(std_msgs_msg_dds__Header_),
    {
        {"stamp", FieldKind::structure, offsetof(std_msgs_msg_dds__Header_, stamp), &builtin_interfaces_Time},
        {"frame_id", FieldKind::string, offsetof(std_msgs_msg_dds__Header_, frame_id)},
    }};
const StructLayout geometry_msgs_PoseStamped{
    "geometry_msgs/msg/PoseStamped",
    sizeof(geometry_msgs_msg_dds__PoseStamped_),
    {
        {"header", FieldKind::structure, offsetof(geometry_msgs_msg_dds__PoseStamped_, header),
         &std_msgs_Header},
        {"pose", FieldKind::structure, offsetof(geometry_msgs_msg_dds__PoseStamped_, pose),
         &geometry_msgs_Pose},
    }};
const StructLayout geometry_msgs_Vector3{
    "geometry_msgs/msg/Vector3",
    sizeof(geometry_msgs_msg_dds__Vector3_),
    {
        {"x", FieldKind::float64, offsetof(geometry_msgs_msg_dds__Vector3_, x)},
        {"y", FieldKind::float64, offsetof(geometry_msgs_msg_dds__Vector3_, y)},
        {"z", FieldKind::float64, offsetof(geometry_msgs_msg_dds__Vector3_, z)},
    }};
const StructLayout geometry_msgs_Twist{
    "geometry_msgs/msg/Twist",
    sizeof(geometry_msgs_msg_dds__Twist_),
    {
        {"linear", FieldKind::structure, offsetof(geometry_msgs_msg_dds__Twist_, linear),
         &geometry_msgs_Vector3},
        {"angular", FieldKind::structure, offsetof(geometry_msgs_msg_dds__Twist_, angular),
         &geometry_msgs_Vector3},
    }};
const StructLayout sensor_msgs_Image{
    "sensor_msgs/msg/Image",
    sizeof(sensor_msgs_msg_dds__Image_),
    {
        {"header", FieldKind::structure, offsetof(sensor_msgs_msg_dds__Image_, header), &std_msgs_Header},
        {"height", FieldKind::uint32, offsetof(sensor_msgs_msg_dds__Image_, height)},
        {"width", FieldKind::uint32, offsetof(sensor_msgs_msg_dds__Image_, width)},
        {"encoding", FieldKind::string, offsetof(sensor_msgs_msg_dds__Image_, encoding)},
        {"is_bigendian", FieldKind::octet, offsetof(sensor_msgs_msg_dds__Image_, is_bigendian)},
        {"step", FieldKind::uint32, offsetof(sensor_msgs_msg_dds__Image_, step)},
        {"data", FieldKind::octets, offsetof(sensor_msgs_msg_dds__Image_, data)},
    }};
const StructLayout sensor_msgs_Imu{
    "sensor_msgs/msg/Imu",
    sizeof(sensor_msgs_msg_dds__Imu_),
    {
        {"header", FieldKind::structure, offsetof(sensor_msgs_msg_dds__Imu_, header), &std_msgs_Header},
        {"orientation", FieldKind::structure, offsetof(sensor_msgs_msg_dds__Imu_, orientation),
         &geometry_msgs_Quaternion},
        {"orientation_covariance", FieldKind::float64_array,
         offsetof(sensor_msgs_msg_dds__Imu_, orientation_covariance), nullptr, 9},
        {"angular_velocity", FieldKind::structure, offsetof(sensor_msgs_msg_dds__Imu_, angular_velocity),
         &geometry_msgs_Vector3},
        {"angular_velocity_covariance", FieldKind::float64_array,
         offsetof(sensor_msgs_msg_dds__Imu_, angular_velocity_covariance), nullptr, 9},
        {"linear_acceleration", FieldKind::structure,
         offsetof(sensor_msgs_msg_dds__Imu_, linear_acceleration), &geometry_msgs_Vector3},
        {"linear_acceleration_covariance", FieldKind::float64_array,
         offsetof(sensor_msgs_msg_dds__Imu_, linear_acceleration_covariance), nullptr, 9},
    }};
const StructLayout sensor_msgs_JointState{
    "sensor_msgs/msg/JointState",
    sizeof(sensor_msgs_msg_dds__JointState_),
    {
        {"header", FieldKind::structure, offsetof(sensor_msgs_msg_dds__JointState_, header),
         &std_msgs_Header},
        {"name", FieldKind::strings, offsetof(sensor_msgs_msg_dds__JointState_, name)},
        {"position", FieldKind::float64s, offsetof(sensor_msgs_msg_dds__JointState_, position)},
        {"velocity", FieldKind::float64s, offsetof(sensor_msgs_msg_dds__JointState_, velocity)},
        {"effort", FieldKind::float64s, offsetof(sensor_msgs_msg_dds__JointState_, effort)},
    }};
const StructLayout sensor_msgs_LaserScan{
    "sensor_msgs/msg/LaserScan",
    sizeof(sensor_msgs_msg_dds__LaserScan_),
    {
        {"header", FieldKind::structure, offsetof(sensor_msgs_msg_dds__LaserScan_, header), &std_msgs_Header},
        {"angle_min", FieldKind::float32, offsetof(sensor_msgs_msg_dds__LaserScan_, angle_min)},
        {"angle_max", FieldKind::float32, offsetof(sensor_msgs_msg_dds__LaserScan_, angle_max)},
        {"angle_increment", FieldKind::float32, offsetof(sensor_msgs_msg_dds__LaserScan_, angle_increment)},
        {"time_increment", FieldKind::float32, offsetof(sensor_msgs_msg_dds__LaserScan_, time_increment)},
        {"scan_time", FieldKind::float32, offsetof(sensor_msgs_msg_dds__LaserScan_, scan_time)},
        {"range_min", FieldKind::float32, offsetof(sensor_msgs_msg_dds__LaserScan_, range_min)},
        {"range_max", FieldKind::float32, offsetof(sensor_msgs_msg_dds__LaserScan_, range_max)},
        {"ranges", FieldKind::float32s, offsetof(sensor_msgs_msg_dds__LaserScan_, ranges)},
        {"intensities", FieldKind::float32s, offsetof(sensor_msgs_msg_dds__LaserScan_, intensities)},
    }};
const StructLayout sensor_msgs_PointField{
    "sensor_msgs/msg/PointField",
    sizeof(sensor_msgs_msg_dds__PointField_),
    {
        {"name", FieldKind::string, offsetof(sensor_msgs_msg_dds__PointField_, name)},
        {"offset", FieldKind::uint32, offsetof(sensor_msgs_msg_dds__PointField_, offset)},
        {"datatype", FieldKind::octet, offsetof(sensor_msgs_msg_dds__PointField_, datatype)},
        {"count", FieldKind::uint32, offsetof(sensor_msgs_msg_dds__PointField_, count)},
    }};
const StructLayout sensor_msgs_PointCloud2{
    "sensor_msgs/msg/PointCloud2",
    sizeof(sensor_msgs_msg_dds__PointCloud2_),
    {
        {"header", FieldKind::structure, offsetof(sensor_msgs_msg_dds__PointCloud2_, header),
         &std_msgs_Header},
        {"height", FieldKind::uint32, offsetof(sensor_msgs_msg_dds__PointCloud2_, height)},
        {"width", FieldKind::uint32, offsetof(sensor_msgs_msg_dds__PointCloud2_, width)},
        {"fields", FieldKind::structures, offsetof(sensor_msgs_msg_dds__PointCloud2_, fields),
         &sensor_msgs_PointField},
        {"is_bigendian", FieldKind::boolean, offsetof(sensor_msgs_msg_dds__PointCloud2_, is_bigendian)},
        {"point_step", FieldKind::uint32, offsetof(sensor_msgs_msg_dds__PointCloud2_, point_step)},
        {"row_step", FieldKind::uint32, offsetof(sensor_msgs_msg_dds__PointCloud2_, row_step)},
        {"data", FieldKind::octets, offsetof(sensor_msgs_msg_dds__PointCloud2_, data)},
        {"is_dense", FieldKind::boolean, offsetof(sensor_msgs_msg_dds__PointCloud2_, is_dense)},
    }};
const StructLayout std_msgs_Bool{"std_msgs/msg/Bool",
                                 sizeof(std_msgs_msg_dds__Bool_),
                                 {
                                     {"data", FieldKind::boolean, offsetof(std_msgs_msg_dds__Bool_, data)},
                                 }};
const StructLayout std_msgs_Float32{
    "std_msgs/msg/Float32",
    sizeof(std_msgs_msg_dds__Float32_),
    {
        {"data", FieldKind::float32, offsetof(std_msgs_msg_dds__Float32_, data)},
    }};
const StructLayout std_msgs_Float64{
    "std_msgs/msg/Float64",
    sizeof(std_msgs_msg_dds__Float64_),
    {
        {"data", FieldKind::float64, offsetof(std_msgs_msg_dds__Float64_, data)},
    }};
const StructLayout std_msgs_Int32{"std_msgs/msg/Int32",
                                  sizeof(std_msgs_msg_dds__Int32_),
                                  {
                                      {"data", FieldKind::int32, offsetof(std_msgs_msg_dds__Int32_, data)},
                                  }};
const StructLayout std_msgs_Int64{"std_msgs/msg/Int64",
                                  sizeof(std_msgs_msg_dds__Int64_),
                                  {
                                      {"data", FieldKind::int64, offsetof(std_msgs_msg_dds__Int64_, data)},
                                  }};
const StructLayout std_msgs_String{"std_msgs/msg/String",
                                   sizeof(std_msgs_msg_dds__String_),
                                   {
                                       {"data", FieldKind::string, offsetof(std_msgs_msg_dds__String_, data)},
                                   }};

const std::vector<Ros2Type>& all_types() {
    static const std::vector<Ros2Type> types{
        {"builtin_interfaces/msg/Time", "builtin_interfaces::msg::dds_::Time_",
         &builtin_interfaces_msg_dds__Time__desc, &builtin_interfaces_Time},
        {"geometry_msgs/msg/Point", "geometry_msgs::msg::dds_::Point_", &geometry_msgs_msg_dds__Point__desc,
         &geometry_msgs_Point},
        {"geometry_msgs/msg/Pose", "geometry_msgs::msg::dds_::Pose_", &geometry_msgs_msg_dds__Pose__desc,
         &geometry_msgs_Pose},
        {"geometry_msgs/msg/PoseStamped", "geometry_msgs::msg::dds_::PoseStamped_",
         &geometry_msgs_msg_dds__PoseStamped__desc, &geometry_msgs_PoseStamped},
        {"geometry_msgs/msg/Quaternion", "geometry_msgs::msg::dds_::Quaternion_",
         &geometry_msgs_msg_dds__Quaternion__desc, &geometry_msgs_Quaternion},
        {"geometry_msgs/msg/Twist", "geometry_msgs::msg::dds_::Twist_", &geometry_msgs_msg_dds__Twist__desc,
         &geometry_msgs_Twist},
        {"geometry_msgs/msg/Vector3", "geometry_msgs::msg::dds_::Vector3_",
         &geometry_msgs_msg_dds__Vector3__desc, &geometry_msgs_Vector3},
        {"sensor_msgs/msg/Image", "sensor_msgs::msg::dds_::Image_", &sensor_msgs_msg_dds__Image__desc,
         &sensor_msgs_Image},
        {"sensor_msgs/msg/Imu", "sensor_msgs::msg::dds_::Imu_", &sensor_msgs_msg_dds__Imu__desc,
         &sensor_msgs_Imu},
        {"sensor_msgs/msg/JointState", "sensor_msgs::msg::dds_::JointState_",
         &sensor_msgs_msg_dds__JointState__desc, &sensor_msgs_JointState},
        {"sensor_msgs/msg/LaserScan", "sensor_msgs::msg::dds_::LaserScan_",
         &sensor_msgs_msg_dds__LaserScan__desc, &sensor_msgs_LaserScan},
        {"sensor_msgs/msg/PointCloud2", "sensor_msgs::msg::dds_::PointCloud2_",
         &sensor_msgs_msg_dds__PointCloud2__desc, &sensor_msgs_PointCloud2},
        {"sensor_msgs/msg/PointField", "sensor_msgs::msg::dds_::PointField_",
         &sensor_msgs_msg_dds__PointField__desc, &sensor_msgs_PointField},
        {"std_msgs/msg/Bool", "std_msgs::msg::dds_::Bool_", &std_msgs_msg_dds__Bool__desc, &std_msgs_Bool},
        {"std_msgs/msg/Float32", "std_msgs::msg::dds_::Float32_", &std_msgs_msg_dds__Float32__desc,
         &std_msgs_Float32},
        {"std_msgs/msg/Float64", "std_msgs::msg::dds_::Float64_", &std_msgs_msg_dds__Float64__desc,
         &std_msgs_Float64},
        {"std_msgs/msg/Header", "std_msgs::msg::dds_::Header_", &std_msgs_msg_dds__Header__desc,
         &std_msgs_Header},
        {"std_msgs/msg/Int32", "std_msgs::msg::dds_::Int32_", &std_msgs_msg_dds__Int32__desc,
         &std_msgs_Int32},
        {"std_msgs/msg/Int64", "std_msgs::msg::dds_::Int64_", &std_msgs_msg_dds__Int64__desc,
         &std_msgs_Int64},
        {"std_msgs/msg/String", "std_msgs::msg::dds_::String_", &std_msgs_msg_dds__String__desc,
         &std_msgs_String},
    };
    return types;
}

}  // namespace

static_assert(sizeof(Sequence) == sizeof(dds_sequence_octet) &&
              offsetof(Sequence, buffer) == offsetof(dds_sequence_octet, _buffer) &&
              offsetof(Sequence, release) == offsetof(dds_sequence_octet, _release));

const Ros2Type* find_type(std::string_view name) {
    // ROS 2 tools also accept "pkg/Name" for "pkg/msg/Name".
    std::string full(name);
    if (const auto slash = full.find('/');
        slash != std::string::npos && full.find('/', slash + 1) == std::string::npos)
        full.insert(slash, "/msg");
    for (const auto& type : all_types()) {
        if (type.name == full)
            return &type;
    }
    return nullptr;
}

std::vector<std::string> type_names() {
    std::vector<std::string> names;
    for (const auto& type : all_types())
        names.push_back(type.name);
    std::sort(names.begin(), names.end());
    return names;
}

}  // namespace plexus::bridge::ros2
