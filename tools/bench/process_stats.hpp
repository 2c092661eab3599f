#pragma once
// CPU time and resident memory of other processes (the daemons, the relays), read from the kernel.

#include <sys/types.h>

#include <vector>

namespace plexus::bench {

/// CPU time (user + system, all threads) used so far by the processes, in seconds.
/// Uses each process's CPU clock (nanosecond resolution) and falls back to utime + stime from
/// /proc/PID/stat (clock-tick resolution, usually 10 ms) where that clock is not available.
double cpu_seconds(const std::vector<pid_t>& pids);

/// Resident memory (VmRSS) of a process in KiB; -1 if unknown.
long rss_kib(pid_t pid);

/// Peak resident memory (VmHWM) of a process in KiB; -1 if unknown.
long peak_rss_kib(pid_t pid);

}  // namespace plexus::bench
