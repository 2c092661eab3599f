#pragma once
// The far end of a scenario for the brokerless systems (Cyclone DDS, iceoryx): a process of its
// own, `plexus-bench peer-far-end`, that either subscribes through the system and reports every
// message it takes, or echoes a ping-pong. Two nodes of a robot are two processes; DDS would hand a
// message from a writer to a reader of the same process without the network, so the measured hop
// must always cross from the measuring process to this one (and back, for the echo).
//
// A far subscriber reads the arrival time (steady clock, one clock for every process) as soon as
// the library hands a message over, then writes a 32-byte report (the message's stamp and that
// time) into a FIFO that the measuring process reads: the report travels after what is measured.
// Reports are held back until 256 are pending or the oldest has waited 1 ms, so that a fast stream
// costs the far end few writes and the measuring process few wake-ups: on a 2-core machine every
// wake-up of the measuring process is CPU that the systems' own threads would otherwise have.
//
// Threading: a FarSubscriber is used by one thread at a time, like every Subscriber; a far-end
// process is one thread of its own (plus its library's).

#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "../child_process.hpp"
#include "pubsub.hpp"
#include "stamp.hpp"

namespace plexus::bench::peers {

/// The arguments of `plexus-bench peer-far-end`.
struct FarEndOptions {
    std::string system;              ///< cyclonedds, cyclonedds-be, iceoryx
    std::string role;                ///< "subscriber" or "echo"
    std::string topic;               ///< what it subscribes to
    std::string answer_topic;        ///< echo: where it publishes the answers
    std::string report;              ///< subscriber: the FIFO its reports go to
    std::size_t queue_capacity = 0;  ///< iceoryx: its subscriber queue's capacity (0: iceoryx's default)
};

/// One message as a far subscriber reports it.
struct Report {
    Stamp stamp;
    std::int64_t arrived_ns = 0;
};

/// The start of a `peer-far-end` command line for `system`: the program and the system's name.
std::vector<std::string> far_end_command(const std::string& self, const std::string& system);

/// In the measuring process: a subscriber whose messages a far-end process receives and reports.
class FarSubscriber final : public Subscriber {
public:
    /// Starts `command` (far_end_command(), then --topic) with a FIFO of its own in `dir`.
    FarSubscriber(std::vector<std::string> command, const std::string& topic, const TempDir& dir);
    ~FarSubscriber() override;
    FarSubscriber(const FarSubscriber&) = delete;
    FarSubscriber& operator=(const FarSubscriber&) = delete;

    /// Gives the message's stamp as its payload: the far end reports nothing else.
    bool receive(std::string& payload, std::chrono::milliseconds timeout) override;
    bool receive_stamp(Arrival& arrival, std::chrono::milliseconds timeout) override;

private:
    /// Reads what the FIFO holds, waiting up to `timeout`; false if nothing came.
    bool fill(std::chrono::milliseconds timeout);

    std::unique_ptr<ChildProcess> process_;
    int fifo_ = -1;
    std::vector<char> buffer_;
    std::size_t begin_ = 0;  ///< the first unread byte of buffer_
    std::size_t end_ = 0;    ///< one past the last
};

/// In the measuring process: an echo in a far-end process, stopped when destroyed.
class FarEcho final : public Echo {
public:
    /// Starts `command` (far_end_command()) echoing `from` on `to`, logging into `dir`.
    FarEcho(std::vector<std::string> command, const std::string& from, const std::string& to,
            const TempDir& dir);

private:
    ChildProcess process_;
};

/// What a far end does after each batch of messages it took: nullopt to stop, or how long it may
/// wait for the next message before it must call again.
using NextWait = std::optional<std::chrono::milliseconds>;

/// After a batch, for a far end that holds nothing back (the echo): wait until SIGTERM is looked at.
NextWait keep_waiting();

/// In a far-end process: collects reports and writes them to the FIFO in batches.
class ReportWriter {
public:
    explicit ReportWriter(const std::string& fifo);
    ~ReportWriter();
    ReportWriter(const ReportWriter&) = delete;
    ReportWriter& operator=(const ReportWriter&) = delete;

    void add(const Stamp& stamp, std::int64_t arrived_ns);
    /// After a batch: writes the pending reports if 256 are pending or the oldest has waited 1 ms.
    /// nullopt once the measuring process has gone (or SIGTERM came).
    NextWait after_batch();

private:
    bool flush();

    int fd_ = -1;
    std::vector<Report> pending_;
    std::int64_t oldest_ns_ = 0;  ///< when the oldest pending report was added
};

/// In a far-end process: from now on SIGTERM only sets a flag that far_end_stopping() reads, so
/// that the loop ends and the process leaves its system cleanly (iceoryx: unregistered from RouDi).
void stop_far_end_on_sigterm();
bool far_end_stopping();

}  // namespace plexus::bench::peers
