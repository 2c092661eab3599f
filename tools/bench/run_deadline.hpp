#pragma once
// A deadline on one benchmark run: a wedged run ends the bench instead of hanging a CI job.

#include <signal.h>
#include <unistd.h>

namespace plexus::bench {

// No healthy run comes near this; a wedged one ends the bench (its children get SIGTERM through
// PR_SET_PDEATHSIG) instead of hanging a CI job.
inline constexpr unsigned run_deadline_s = 120;

inline void on_deadline(int /*signal*/) {
    static const char message[] = "plexus-bench: a run took longer than 120 s; giving up\n";
    [[maybe_unused]] auto ignored = ::write(2, message, sizeof message - 1);
    ::_exit(3);
}

/// Arms the deadline for the duration of one run.
class RunDeadline {
public:
    RunDeadline() {
        ::signal(SIGALRM, on_deadline);
        ::alarm(run_deadline_s);
    }
    ~RunDeadline() { ::alarm(0); }
    RunDeadline(const RunDeadline&) = delete;
    RunDeadline& operator=(const RunDeadline&) = delete;
};

}  // namespace plexus::bench
