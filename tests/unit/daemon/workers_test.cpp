// The monitor workers' lifetime: stages share them, so the last owner may let go anywhere,
// including on one of the workers' own threads.
#include "monitor/workers.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>

#include <boost/asio/post.hpp>

namespace plexus::daemon::monitor {
namespace {

using namespace std::chrono_literals;

TEST(Workers_test, TheLastOwnerMayLetGoOnAWorkersOwnThread) {
    // A stage freed by its last handler frees the workers it held on their own thread (CI's ASan
    // stage caught the pool freed under that handler's strand).
    for (int round = 0; round < 20; ++round) {
        auto workers = std::make_shared<Workers>(2);
        std::promise<void> let_go, released;
        auto done = released.get_future();
        std::weak_ptr<Workers> watch = workers;
        // The strand is a temporary: like a stage's, it must not outlive the workers.
        boost::asio::post(workers->make_strand(),
                          [owner = workers, others_gone = let_go.get_future(), &released]() mutable {
                              others_gone.wait();
                              owner.reset();  // the last reference: ~Workers runs here, on a worker
                              released.set_value();
                          });
        workers.reset();
        let_go.set_value();
        ASSERT_EQ(done.wait_for(10s), std::future_status::ready) << "round " << round;
        EXPECT_TRUE(watch.expired());
    }
}

TEST(Workers_test, FinishRunsWhatWasPostedThenTheThreadsEnd) {
    Workers workers(2);
    std::atomic<int> ran = 0;
    for (int i = 0; i < 100; ++i)
        boost::asio::post(workers.make_strand(), [&ran] { ++ran; });
    workers.finish();
    EXPECT_EQ(ran.load(), 100);
}

}  // namespace
}  // namespace plexus::daemon::monitor
