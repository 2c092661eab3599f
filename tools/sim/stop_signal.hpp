#pragma once
// Ctrl-C and SIGTERM for the simulation programs: the handler only sets a flag, and each program's
// loop checks it at least every 100 ms, then leaves normally so that its ports are closed (and what
// was written is flushed) by their destructors.
#include <csignal>

namespace plexus::sim {

inline volatile std::sig_atomic_t stop_flag = 0;

inline void request_stop(int) {
    stop_flag = 1;
}

inline void install_stop_handlers() {
    std::signal(SIGINT, request_stop);
    std::signal(SIGTERM, request_stop);
}

inline bool stop_requested() {
    return stop_flag != 0;
}

}  // namespace plexus::sim
