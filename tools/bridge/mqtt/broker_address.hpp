#pragma once
// The --broker flag: HOST:PORT (an IPv6 host in brackets), checked at start so that a typo is a
// usage error rather than a bridge retrying a broker that cannot exist.
#include <string>

namespace plexus::bridge {

struct BrokerAddress {
    std::string host;
    int port = 1883;
};

/// Parses `HOST:PORT` or `[V6]:PORT`; throws UsageError naming --broker when it is malformed.
BrokerAddress parse_broker(const std::string& text);

}  // namespace plexus::bridge
