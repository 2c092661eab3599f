#pragma once
// A what-if re-run as an SVG timeline, in the style of tools/timeline/plexus-timeline-svg
// (docs/fetch-timeline.svg): one lane per source with a recorded row and a what-if row, a mark
// per decided message (full height and the source's colour when delivered, a short grey one when
// dropped, with the outcome in its tooltip), the changed ones ringed in red and repeated on a
// lane of their own at the top, a time axis in seconds from the recording's start, a legend.

#include <string>

#include "recorded_port.hpp"
#include "what_if.hpp"

namespace plexus::record {

/// The whole SVG document.
std::string timeline_svg(const RecordedPort& port, const WhatIfResult& result, const std::string& title);

}  // namespace plexus::record
