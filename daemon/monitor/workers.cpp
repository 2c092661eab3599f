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

Workers::Workers(std::size_t threads) : threads_(threads_for(threads)), pool_(threads_) {}

Workers::~Workers() {
    pool_.stop();
    pool_.join();
}

WorkerStrand Workers::make_strand() {
    return boost::asio::make_strand(pool_.get_executor());
}

void Workers::finish() {
    pool_.join();
}

}  // namespace plexus::daemon::monitor
