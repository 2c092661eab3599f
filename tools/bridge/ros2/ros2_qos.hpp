#pragma once
// The QoS of a ROS 2 mapping: ROS 2's default (reliable, volatile, keep last 10) unless the command
// line or the mapping asks otherwise; and ROS 2's topic names on DDS ("/chatter" is "rt/chatter").
#include <memory>
#include <string>

#include <dds/dds.h>

namespace plexus::bridge::ros2 {

struct Qos {
    bool reliable = true;
    bool transient_local = false;
    int depth = 10;
};

/// `text`: comma-separated reliable | best-effort | volatile | transient-local | depth=N, over
/// `defaults`. Throws UsageError naming `where` for anything else.
Qos parse_qos(const std::string& text, Qos defaults, const std::string& where);

struct QosDeleter {
    void operator()(dds_qos_t* qos) const { dds_delete_qos(qos); }
};
using QosPtr = std::unique_ptr<dds_qos_t, QosDeleter>;

/// A reader's QoS: `qos`, and the bridge's own writers ignored.
QosPtr reader_qos(const Qos& qos);
QosPtr writer_qos(const Qos& qos);

/// "rt/chatter" for "/chatter" (or "chatter"); throws UsageError for a name ROS 2 would refuse.
std::string dds_topic_name(const std::string& ros_topic, const std::string& where);

}  // namespace plexus::bridge::ros2
