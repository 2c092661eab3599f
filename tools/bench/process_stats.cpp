#include "process_stats.hpp"

#include <time.h>
#include <unistd.h>

#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "child_process.hpp"

namespace plexus::bench {

namespace {

double stat_cpu_seconds(pid_t pid) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
    std::string line;
    if (!std::getline(in, line))
        throw std::runtime_error("cannot read /proc/" + std::to_string(pid) + "/stat");
    // The command name may hold spaces and parentheses: fields are counted after the last ')'.
    std::istringstream fields(line.substr(line.rfind(')') + 2));
    std::string field;
    unsigned long long utime = 0;
    unsigned long long stime = 0;
    for (int index = 3; fields >> field; ++index) {
        if (index == 14)
            utime = std::stoull(field);
        if (index == 15) {
            stime = std::stoull(field);
            break;
        }
    }
    return static_cast<double>(utime + stime) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

long status_kib(pid_t pid, const std::string& key) {
    std::ifstream in("/proc/" + std::to_string(pid) + "/status");
    std::string line;
    while (std::getline(in, line)) {
        if (line.rfind(key, 0) == 0)
            return std::stol(line.substr(key.size()));
    }
    return -1;
}

}  // namespace

double cpu_seconds(const std::vector<pid_t>& pids) {
    double total = 0;
    for (const pid_t pid : pids) {
        clockid_t clock{};
        timespec now{};
        if (::clock_getcpuclockid(pid, &clock) == 0 && ::clock_gettime(clock, &now) == 0) {
            total += static_cast<double>(now.tv_sec) + static_cast<double>(now.tv_nsec) * 1e-9;
        } else {
            total += stat_cpu_seconds(pid);
        }
    }
    return total;
}

long rss_kib(pid_t pid) {
    return status_kib(pid, "VmRSS:");
}

long peak_rss_kib(pid_t pid) {
    return status_kib(pid, "VmHWM:");
}

std::string load_average() {
    const std::string text = read_file("/proc/loadavg");  // "1min 5min 15min running/total last-pid"
    return text.substr(0, text.find(' ', text.find(' ', text.find(' ') + 1) + 1));
}

}  // namespace plexus::bench
