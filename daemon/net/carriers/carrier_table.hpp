#pragma once
// Threading: none; the table is constant.
//
// The carriers this daemon knows, by base name: the one place that lists them (as the control
// plane's op table lists the ops). To add a carrier: write its class beside the others, add a row
// (carrier_table.cpp) and its name to proto::CarrierSupport::bases, which clients check carrier
// strings against (a unit test keeps the two lists equal).

#include <string_view>
#include <vector>

#include "carrier.hpp"
#include "plexus/proto/bytes.hpp"

namespace plexus::daemon::carriers {

/// The carrier whose base name is `base` ("tcp", "udp", "mcast", "local"); an Error naming it and
/// the carriers there are when there is none.
proto::Result<const Carrier*> find_carrier(std::string_view base);

/// The carrier of a connect that names none: `local` when both ports are on this daemon, else `tcp`.
const Carrier& automatic_carrier(bool both_ports_here);

/// The base names of every carrier in the table, in table order.
std::vector<std::string_view> carrier_names();

}  // namespace plexus::daemon::carriers
