#include "core/router.hpp"

#include <gtest/gtest.h>

namespace plexus::daemon {
namespace {

std::shared_ptr<Connection> local_connection(const std::shared_ptr<Port>& from,
                                             const std::shared_ptr<Port>& to) {
    auto connection = std::make_shared<Connection>();
    connection->source = from->name();
    connection->destination = to->name();
    connection->carrier = "local";
    connection->sink = to;
    return connection;
}

TEST(Router_test, OpenRefusesInvalidAndDuplicateNames) {
    Router router;
    EXPECT_TRUE(router.open("/a", 1, QueuePolicy::strict, 4).ok());
    auto duplicate = router.open("/a", 2, QueuePolicy::strict, 4);
    ASSERT_FALSE(duplicate.ok());
    EXPECT_NE(duplicate.error().message.find("already open"), std::string::npos);
    EXPECT_FALSE(router.open("a", 1, QueuePolicy::strict, 4).ok());
    EXPECT_FALSE(router.open("/b", 1, QueuePolicy::strict, 0).ok());
}

TEST(Router_test, RouteFansOutToEveryConnectionAndCounts) {
    Router router;
    auto source = *router.open("/source", 1, QueuePolicy::strict, 4);
    auto left = *router.open("/left", 2, QueuePolicy::strict, 4);
    auto right = *router.open("/right", 3, QueuePolicy::latest, 4);
    ASSERT_TRUE(router.add(source, local_connection(source, left)).ok());
    ASSERT_TRUE(router.add(source, local_connection(source, right)).ok());
    int woken = 0;
    left->on_readable = [&] { ++woken; };

    Router::route(*source, Message{nullptr, {}, 1});
    Router::route(*source, Message{nullptr, {}, 2});

    EXPECT_EQ(source->written, 2u);
    EXPECT_EQ(left->received, 2u);
    EXPECT_EQ(right->queue().depth(), 2u);
    EXPECT_EQ(woken, 1) << "the reader is woken when its queue stops being empty, not per message";
    EXPECT_EQ(source->outgoing[0]->sent, 2u);
}

TEST(Router_test, AFullStrictDestinationBlocksTheWriterAndALatestOneDoesNot) {
    Router router;
    auto source = *router.open("/source", 1, QueuePolicy::strict, 4);
    auto strict = *router.open("/strict", 2, QueuePolicy::strict, 1);
    auto latest = *router.open("/latest", 3, QueuePolicy::latest, 1);
    ASSERT_TRUE(router.add(source, local_connection(source, latest)).ok());
    Router::route(*source, Message{nullptr, {}, 1});
    Router::route(*source, Message{nullptr, {}, 2});
    EXPECT_FALSE(Router::blocked(*source));

    ASSERT_TRUE(router.add(source, local_connection(source, strict)).ok());
    Router::route(*source, Message{nullptr, {}, 3});
    EXPECT_TRUE(Router::blocked(*source));
    strict->queue().pop();
    EXPECT_FALSE(Router::blocked(*source));
}

TEST(Router_test, ConnectingTheSamePairTwiceIsRefused) {
    Router router;
    auto a = *router.open("/a", 1, QueuePolicy::strict, 4);
    auto b = *router.open("/b", 1, QueuePolicy::strict, 4);
    ASSERT_TRUE(router.add(a, local_connection(a, b)).ok());
    auto again = router.add(a, local_connection(a, b));
    ASSERT_FALSE(again.ok());
    EXPECT_NE(again.error().message.find("already connected"), std::string::npos);
}

TEST(Router_test, ClosingAPortRemovesConnectionsFromAndToIt) {
    Router router;
    auto a = *router.open("/a", 1, QueuePolicy::strict, 4);
    auto b = *router.open("/b", 2, QueuePolicy::strict, 4);
    auto c = *router.open("/c", 3, QueuePolicy::strict, 4);
    ASSERT_TRUE(router.add(a, local_connection(a, b)).ok());
    ASSERT_TRUE(router.add(b, local_connection(b, c)).ok());
    bool told = false;
    auto owner = std::make_shared<int>(0);
    b->on_close(owner, [&] { told = true; });

    auto removed = router.close("/b");

    EXPECT_EQ(removed.size(), 2u);
    EXPECT_TRUE(a->outgoing.empty());
    EXPECT_TRUE(b->closed());
    EXPECT_TRUE(told);
    EXPECT_EQ(router.find("/b"), nullptr);
}

TEST(Router_test, ClosingAPortSkipsAndForgetsCallbacksWhoseOwnerIsGone) {
    Router router;
    auto port = *router.open("/p", 1, QueuePolicy::strict, 4);
    int calls = 0;
    for (int i = 0; i < 1000; ++i) {
        auto gone = std::make_shared<int>(i);
        port->on_close(gone, [&] { ++calls; });  // `gone` ends with this iteration
    }
    auto alive = std::make_shared<int>(0);
    port->on_close(alive, [&] { calls += 1000; });

    router.close("/p");

    EXPECT_EQ(calls, 1000);  // only the living owner's callback ran
}

TEST(Router_test, RemoveByPairReportsWhetherThereWasOne) {
    Router router;
    auto a = *router.open("/a", 1, QueuePolicy::strict, 4);
    auto b = *router.open("/b", 1, QueuePolicy::strict, 4);
    ASSERT_TRUE(router.add(a, local_connection(a, b)).ok());
    EXPECT_NE(router.remove("/a", "/b"), nullptr);
    EXPECT_EQ(router.remove("/a", "/b"), nullptr);
    EXPECT_EQ(router.remove("/nobody", "/b"), nullptr);
}

}  // namespace
}  // namespace plexus::daemon
