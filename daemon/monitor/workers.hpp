#pragma once
// Threading: made and stopped on the daemon's thread; its threads run monitor work only.
//
// The threads port monitors run on, so that a script (however slow, within its budget) delays only
// its own connection: the daemon's thread keeps doing the I/O, the control plane, the other
// connections and the signals. Each connection side's monitors run on a strand of their own: one
// message at a time, in order, on whichever worker is free (monitor/stage.hpp).

#include <cstddef>
#include <memory>

#include <boost/asio/strand.hpp>
#include <boost/asio/thread_pool.hpp>

#include "loop_stand_in.hpp"

namespace plexus::daemon::monitor {

using WorkerStrand = boost::asio::strand<boost::asio::thread_pool::executor_type>;

class Workers {
public:
    /// `threads` 0: one per core the machine has. With `loop` (the daemon's event loop), cheap
    /// monitors may run inline on it, and a LoopStandIn stands by for those that overrun.
    explicit Workers(std::size_t threads, boost::asio::io_context* loop = nullptr);
    /// Stops the threads and waits for them, except when the last owner lets go on one of them (a
    /// stage freed by its last handler): a thread cannot wait for itself, so another one does.
    ~Workers();
    Workers(const Workers&) = delete;
    Workers& operator=(const Workers&) = delete;

    WorkerStrand make_strand();
    std::size_t threads() const { return threads_; }
    /// Null without a loop: monitors always run on workers.
    LoopStandIn* stand_in() { return stand_in_.get(); }
    /// Waits until every piece of work posted so far has run (closed stages skip their messages,
    /// and each script call ends within its budget), then the threads end.
    void finish();

private:
    std::size_t threads_;
    std::unique_ptr<boost::asio::thread_pool> pool_;  ///< a pointer: may be handed to a joiner
    std::unique_ptr<LoopStandIn> stand_in_;
};

/// How many of a monitor's publish calls led to the message the current thread is processing
/// (Message::publish_depth); set by the stage around each message.
int current_publish_depth();

}  // namespace plexus::daemon::monitor
