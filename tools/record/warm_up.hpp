#pragma once
// Used by one thread.
//
// A recording starts while the port is running: a connection's stimulation (recv.priority) may
// come from messages before the first one recorded, which the re-run never sees. Its decisions
// may depend on that past until it cannot count any more, for every stimulated connection of the
// port, in the recording and in the re-run alike (what_if.cpp leaves out of the comparison the
// messages of that window that the recorded carriers' own re-run does not reproduce):
//  - after a stimulation that fixes the state whatever came before: with st >= 1 and no resting
//    (tr = 0), a message sets S to 1 and Ta to its time, whatever S was;
//  - or after a quiet spell longer than tc + tr since the recording's start or since the
//    connection's last stimulation: S has decayed to 0 and any rest is over;
//  - and never before the longest tc + tr from the start: a connection that sent nothing during
//    the recording has no channel in it, and may have been stimulated just before the start.
// The events a monitor set before the recording, and a script's own state, are not covered (the
// recording does not hold them); see docs/WHAT_IF.md.

#include <string>
#include <vector>

#include "recorded_port.hpp"

namespace plexus::record {

class WarmUp {
public:
    /// `carriers`: what each connection was re-run with; `stimulated`: per message, whether the
    /// re-run's message reached its connection's stimulation.
    WarmUp(const RecordedPort& port, const std::vector<std::string>& carriers,
           const std::vector<char>& stimulated);

    /// Whether a decision at `time` (arbitration clock) may still depend on the unrecorded past.
    bool unsettled(double time) const { return time < settled_at_; }
    /// From when every decision is trusted.
    double settled_at() const { return settled_at_; }

private:
    double settled_at_;
};

}  // namespace plexus::record
