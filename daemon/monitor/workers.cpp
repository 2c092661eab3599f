#include "workers.hpp"

#include <algorithm>
#include <thread>

#include <boost/asio/post.hpp>

namespace plexus::daemon::monitor {

namespace {

std::size_t threads_for(std::size_t asked) {
    if (asked > 0)
        return asked;
    return std::max<std::size_t>(1, std::thread::hardware_concurrency());
}

}  // namespace

Workers::Workers(std::size_t threads, boost::asio::io_context* loop)
    : threads_(threads_for(threads)), pool_(std::make_unique<boost::asio::thread_pool>(threads_)) {
    if (loop)
        stand_in_ = std::make_unique<LoopStandIn>(*loop);
}

Workers::~Workers() {
    pool_->stop();
    if (pool_->get_executor().running_in_this_thread()) {
        // Joining here would free the pool under the handler still running on this thread (its
        // strand's invoker touches the pool after the handler returns). A thread of its own
        // destroys the pool, and so joins this thread, once that handler is over.
        std::thread([pool = std::move(pool_)]() mutable { pool.reset(); }).detach();
        return;
    }
    pool_->join();
}

WorkerStrand Workers::make_strand() {
    return boost::asio::make_strand(pool_->get_executor());
}

void Workers::finish() {
    pool_->join();
}

}  // namespace plexus::daemon::monitor
