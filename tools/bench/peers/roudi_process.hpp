#pragma once
// RouDi, iceoryx's daemon (`iox-roudi`, Debian's `iceoryx` package), started by a run of the
// iceoryx peer with a configuration of its own: one shared-memory segment with one mempool whose
// chunks fit the run's messages exactly.
//
// RouDi is one per machine: it holds /tmp/iox-unique-roudi.lock, and its shared memory has fixed
// names (/dev/shm/iceoryx_mgmt, /dev/shm/<user>). A RouDi that is already running is refused with
// a message that says so, rather than measured with another configuration or disturbed.
//
// RouDi outlives the run's process, briefly: when it stops it sends SIGTERM to every process still
// registered with it, and waits for them to go, so it must not be stopped by a process that is
// still registered. The run process leaves it running; the iceoryx runtime unregisters when the
// process exits (it is a static), and then RouDi gets SIGTERM from PR_SET_PDEATHSIG (ChildProcess),
// shuts down with no one left and removes its shared memory. The next run waits for the lock.

#include <sys/types.h>

#include <cstddef>
#include <memory>

#include "../child_process.hpp"

namespace plexus::bench::peers {

class RoudiProcess {
public:
    /// Writes the configuration (`chunk_count` chunks of `chunk_size` bytes of payload) into `dir`,
    /// starts iox-roudi and waits until it is ready for clients. Throws if RouDi is not installed,
    /// if another RouDi holds the lock (after waiting a little for a previous run's to finish), or
    /// if it does not start.
    RoudiProcess(const TempDir& dir, std::size_t chunk_size, std::size_t chunk_count);
    /// Leaves RouDi running, to stop when this process has exited (see above).
    ~RoudiProcess();
    RoudiProcess(const RoudiProcess&) = delete;
    RoudiProcess& operator=(const RoudiProcess&) = delete;

    pid_t pid() const { return process_->pid(); }

private:
    std::unique_ptr<ChildProcess> process_;
};

}  // namespace plexus::bench::peers
