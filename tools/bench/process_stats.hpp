#pragma once
// CPU time and resident memory of other processes (the daemons, the relays), and the load on the
// machine around a measurement, read from the kernel.

#include <sys/types.h>

#include <string>
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

/// The load average over 1, 5 and 15 minutes, as /proc/loadavg says it ("1.20 0.90 0.75").
std::string load_average();

}  // namespace plexus::bench
