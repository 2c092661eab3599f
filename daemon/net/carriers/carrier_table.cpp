// The carrier table (carrier_table.hpp).
#include "carrier_table.hpp"

#include <algorithm>
#include <iterator>
#include <string>

#include "local.hpp"
#include "mcast.hpp"
#include "tcp.hpp"
#include "udp.hpp"

namespace plexus::daemon::carriers {

namespace {

const TcpCarrier tcp{};
const UdpCarrier udp{};
const McastCarrier mcast{};
const LocalCarrier local{};

const Carrier* const table[] = {&tcp, &udp, &mcast, &local};

}  // namespace

proto::Result<const Carrier*> find_carrier(std::string_view base) {
    const auto* row = std::find_if(std::begin(table), std::end(table),
                                   [&](const Carrier* carrier) { return carrier->name() == base; });
    if (row != std::end(table))
        return *row;
    std::string known;
    for (const Carrier* carrier : table)
        known += (known.empty() ? "" : ", ") + std::string(carrier->name());
    return proto::Error{"unknown carrier '" + std::string(base) + "' (this daemon knows " + known + ")"};
}

const Carrier& automatic_carrier(bool both_ports_here) {
    // In the daemon when it can be (no copy, no socket); else the reliable, ordered one.
    if (both_ports_here)
        return local;
    return tcp;
}

std::vector<std::string_view> carrier_names() {
    std::vector<std::string_view> names;
    for (const Carrier* carrier : table)
        names.push_back(carrier->name());
    return names;
}

}  // namespace plexus::daemon::carriers
