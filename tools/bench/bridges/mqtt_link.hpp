#pragma once
// A Link over MQTT (libmosquitto, MQTT v5): publishes raw payloads on one topic, receives on
// another, QoS 0 or 1.
#include <memory>
#include <string>

#include "link.hpp"

namespace plexus::bench::bridges {

std::unique_ptr<Link> make_mqtt_link(const std::string& host, int port, const std::string& out,
                                     const std::string& in, int qos);

}  // namespace plexus::bench::bridges
