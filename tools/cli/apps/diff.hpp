#pragma once
// `plexus up FILE --diff`: what differs between the file and the live system; changes nothing.

#include <vector>

#include "plan.hpp"

namespace plexus::cli {

/// Prints each difference on stdout; 0 when there is none, 1 when there is drift.
int print_diff(const app::App& app, const std::vector<ComponentStep>& components, LiveSystem& live);

}  // namespace plexus::cli
