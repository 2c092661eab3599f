#pragma once
// The ROS 2 message types plexus-bridge knows (docs/BRIDGES.md lists them), each as the C struct
// Cyclone's idlc generated from tools/bridge/ros2/idl and a table of its fields: name, kind and
// offset. One table-driven converter (ros2_convert) then maps any of them to a Plexus map and back,
// instead of a pair of hand-written functions per type.
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include <dds/dds.h>

namespace plexus::bridge::ros2 {

enum class FieldKind {
    boolean,
    octet,  ///< uint8 / byte
    int32,
    uint32,
    int64,
    float32,
    float64,
    string,         ///< char*
    structure,      ///< a nested message, `nested`
    octets,         ///< sequence<octet>: a Plexus blob, copied as a whole (Image.data, PointCloud2.data)
    float32s,       ///< sequence<float>: a list of numbers
    float64s,       ///< sequence<double>
    strings,        ///< sequence<string>: a list of texts
    structures,     ///< sequence<nested>: a list of maps
    float64_array,  ///< double[count]: a list of exactly `count` numbers
};

struct StructLayout;

struct Field {
    const char* name;
    FieldKind kind;
    std::size_t offset;
    const StructLayout* nested = nullptr;  ///< structure, structures
    std::size_t count = 0;                 ///< float64_array
    double default_value = 0;              ///< a number a Plexus map leaves out (Quaternion.w: 1)
};

struct StructLayout {
    const char* name;  ///< "geometry_msgs/msg/Twist"
    std::size_t size;  ///< sizeof the C struct
    std::vector<Field> fields;
};

/// Cyclone's view of every `dds_sequence_T` idlc generates: the same four members for every T.
struct Sequence {
    std::uint32_t maximum;
    std::uint32_t length;
    void* buffer;
    bool release;
};

struct Ros2Type {
    std::string name;      ///< as ROS 2 writes it: "std_msgs/msg/String"
    std::string dds_name;  ///< on the wire: "std_msgs::msg::dds_::String_"
    const dds_topic_descriptor_t* descriptor;
    const StructLayout* layout;
};

/// The type called `name` ("std_msgs/msg/String"; "std_msgs/String" is taken too); null if unknown.
const Ros2Type* find_type(std::string_view name);
/// Every known type's name, sorted: what an error about an unknown type lists.
std::vector<std::string> type_names();

}  // namespace plexus::bridge::ros2
