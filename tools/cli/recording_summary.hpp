#pragma once
// `plexus record --info FILE`: what a recording holds.

#include <string>

namespace plexus::cli {

/// Prints the ports, connections, counts, time span and size of a recording; exit 2 (usage)
/// with the offset for a file that is not a readable recording.
int recording_info(const std::string& file, bool json);

}  // namespace plexus::cli
