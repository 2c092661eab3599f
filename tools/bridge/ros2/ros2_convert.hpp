#pragma once
// A ROS 2 message (the C struct of ros2_types) to a Plexus value and back, field by field through
// the type's layout: a message becomes a map of its fields; uint8 sequences (Image.data,
// PointCloud2.data) a blob copied in one piece, other sequences lists. The way back takes the
// same shapes (and a list of small numbers for a uint8 sequence); a field the map leaves out keeps
// its default (0, "", empty, Quaternion.w 1); a field the type does not have, or a value of the wrong
// kind, is an error naming the field.
#include <deque>
#include <string>
#include <vector>

#include <plexus/client.hpp>

#include "ros2_types.hpp"

namespace plexus::bridge::ros2 {

/// The Plexus value of the sample at `sample`, laid out as `layout`.
Value to_value(const void* sample, const StructLayout& layout);

/// Builds C samples from Plexus values. The sample's strings and sequences point into storage the
/// builder owns (or into the value itself, for blobs): keep the builder and the value alive until
/// the sample is written, then clear() or destroy the builder.
class SampleBuilder {
public:
    /// Fills `sample` (of `layout.size` bytes, zeroed first) from `value`; returns "" or the error,
    /// "linear.x: expected a number, not a text".
    std::string fill(const Value& value, const StructLayout& layout, void* sample);
    /// Frees what the last samples pointed into.
    void clear();

private:
    std::string fill_struct(const Value& value, const StructLayout& layout, char* at,
                            const std::string& path);
    std::string fill_field(const Value& value, const Field& field, char* at, const std::string& path);
    char* text(const std::string& value);
    void* bytes(std::size_t size);

    std::deque<std::string> texts_;
    std::vector<std::vector<char>> blocks_;
};

}  // namespace plexus::bridge::ros2
