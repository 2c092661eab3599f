#pragma once
// Threading: start, stop, status and the taps run on the daemon's thread; the event observers run
// on whatever thread changes a port's events (a monitor's worker), under the port's arbiter lock;
// the file is written by the recorder's own thread. Lock order: an arbiter's lock, then queue_mutex_
// (a leaf: nothing is called while it is held).
//
// A recording: taps on ports of this daemon (core/port_tap.hpp) hand every message, decision and
// event, without copying a payload (a Message holds its chunk), to a queue that the recorder's
// thread drains into the file (RecordingFiles). The data path never waits for the disk: past
// `backlog_bytes` waiting, what comes is counted lost, never silently dropped.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include <nlohmann/json.hpp>

#include "arbitration/clock.hpp"
#include "core/port.hpp"
#include "recording_files.hpp"

namespace plexus::daemon::record {

struct RecorderOptions {
    std::string path;
    std::string node;
    std::uint64_t max_bytes = 0;               ///< 0: no limit; past it the recording ends
    std::uint64_t split_bytes = 0;             ///< 0: one file
    std::uint64_t backlog_bytes = 256u << 20;  ///< waiting for the disk; past it, counted lost
};

class Recorder {
public:
    /// Creates the file and puts taps on `ports` (none of them recorded already).
    static proto::Result<std::unique_ptr<Recorder>> start(std::vector<std::shared_ptr<Port>> ports,
                                                          const arbitration::Clock& clock,
                                                          RecorderOptions options);
    /// Stops (if still going) and waits for the file to be closed.
    ~Recorder();
    Recorder(const Recorder&) = delete;
    Recorder& operator=(const Recorder&) = delete;

    /// Takes the taps off the ports; the thread writes what waits, the end note, and closes the
    /// file. `reason` goes into the end note. Does not wait (see finished()).
    void stop(const std::string& reason);
    /// The thread has closed the file (after stop(), a full disk or the size limit).
    bool finished() const { return finished_.load(); }
    /// The recording cannot go on (the disk is full, a limit was reached): the daemon stops it.
    bool ended() const { return ended_.load(); }
    /// {"files", "ports", "messages", "decisions", "events", "bytes", "lost_messages",
    /// "lost_bytes", "done", "error", "reason"}.
    nlohmann::json status() const;

private:
    class Watch;
    struct Entry;
    struct Connection;

    Recorder(RecorderOptions options, const arbitration::Clock& clock);
    void push(Entry entry, std::size_t bytes);
    void not_recordable(std::uint64_t messages);
    void run();
    void write(Entry& entry);
    void end(const std::string& reason);
    /// Copies the files' counts for status(); `final` once nothing more will be written.
    void note_progress(bool final);

    RecorderOptions options_;
    const arbitration::Clock& clock_;
    std::vector<std::shared_ptr<Watch>> watches_;  ///< the daemon's thread's; empty once stopped
    std::vector<std::string> watch_names_;         ///< the recorded ports, by the index events name
    /// Atomic: ports on several data threads (`--threads`) meet new connections at once.
    std::atomic<std::uint32_t> next_connection_{0};
    std::unique_ptr<RecordingFiles> files_;  ///< the thread's, once it runs
    std::vector<Connection> connections_;    ///< the thread's: by the index entries name
    std::string decision_buffer_;            ///< the thread's: one decision's text at a time

    mutable std::mutex queue_mutex_;
    std::condition_variable wake_;
    std::deque<Entry> queue_;
    std::size_t queued_bytes_ = 0;
    bool stopping_ = false;
    std::string reason_;
    // Counted under queue_mutex_ (on the daemon's thread or a worker), read by status().
    std::uint64_t lost_in_queue_ = 0;
    std::uint64_t lost_bytes_in_queue_ = 0;
    std::uint64_t not_recordable_ = 0;  ///< payloads in a writer's shared memory

    // Written by the thread, read by status() on the daemon's thread.
    mutable std::mutex progress_mutex_;
    std::uint64_t messages_ = 0;  ///< handed to the files
    std::uint64_t kept_ = 0;      ///< in the files
    std::uint64_t decisions_ = 0;
    std::uint64_t events_ = 0;
    std::uint64_t bytes_ = 0;
    std::uint64_t lost_in_file_ = 0;
    std::uint64_t lost_bytes_in_file_ = 0;
    std::string error_;
    std::vector<std::string> file_names_;

    std::atomic<bool> ended_{false};
    std::atomic<bool> finished_{false};
    std::thread thread_;
};

}  // namespace plexus::daemon::record
