#include "names/registry.hpp"

#include <gtest/gtest.h>

namespace plexus::daemon::names {
namespace {

using namespace std::chrono_literals;

TEST(Registry_test, ANodeNameHeldByALiveSessionIsRefusedToAnother) {
    Registry registry(2s);
    ASSERT_TRUE(registry.register_node("n1", "127.0.0.1:1000", 1).ok());
    auto second = registry.register_node("n1", "127.0.0.1:2000", 2);
    ASSERT_FALSE(second.ok());
    EXPECT_NE(second.error().message.find("already registered"), std::string::npos);
}

TEST(Registry_test, WhatAPeerRegistersIsCheckedAndBounded) {
    Registry registry(2s);
    EXPECT_FALSE(registry.register_node(std::string(300, 'n'), "h:1", 1).ok());
    EXPECT_FALSE(registry.register_node("n", std::string(300, 'a'), 1).ok());
    ASSERT_TRUE(registry.register_node("n", "h:1", 1).ok());
    ASSERT_TRUE(registry.register_port("/a", 1).ok());
    auto bad_name = registry.add_connection({"not a port", "/b", "tcp", false}, 1);
    ASSERT_FALSE(bad_name.ok());
    EXPECT_FALSE(registry.add_connection({"/a", "/b", std::string(5000, 'c'), false}, 1).ok());
    for (std::size_t i = 0; i < max_connections; ++i)
        ASSERT_TRUE(registry.add_connection({"/a", "/b" + std::to_string(i), "tcp", false}, 1).ok()) << i;
    auto one_too_many = registry.add_connection({"/a", "/c", "tcp", false}, 1);
    ASSERT_FALSE(one_too_many.ok());
    EXPECT_NE(one_too_many.error().message.find("already knows"), std::string::npos);
    // An existing one may still be updated.
    EXPECT_TRUE(registry.add_connection({"/a", "/b0", "udp", true}, 1).ok());
    for (std::uint64_t i = 2; i <= max_nodes; ++i)
        ASSERT_TRUE(registry.register_node("n" + std::to_string(i), "h:1", i).ok()) << i;
    EXPECT_FALSE(registry.register_node("one more", "h:1", max_nodes + 1).ok());
}

TEST(Registry_test, PortsNeedANodeAndUniqueNames) {
    Registry registry(2s);
    EXPECT_FALSE(registry.register_port("/a", 1).ok());
    ASSERT_TRUE(registry.register_node("n1", "h:1", 1).ok());
    ASSERT_TRUE(registry.register_node("n2", "h:2", 2).ok());
    ASSERT_TRUE(registry.register_port("/a", 1).ok());
    EXPECT_TRUE(registry.register_port("/a", 1).ok()) << "the owner may register again (after a reconnect)";
    auto clash = registry.register_port("/a", 2);
    ASSERT_FALSE(clash.ok());
    EXPECT_NE(clash.error().message.find("already exists on node 'n1'"), std::string::npos);
    EXPECT_FALSE(registry.register_port("bad name", 1).ok());
    auto entry = registry.lookup("/a");
    ASSERT_TRUE(entry.has_value());
    EXPECT_EQ(entry->address, "h:1");
}

TEST(Registry_test, AClosedSessionsPortsStayForTheGracePeriodThenGo) {
    Registry registry(2s);
    ASSERT_TRUE(registry.register_node("n1", "h:1", 1).ok());
    ASSERT_TRUE(registry.register_port("/a", 1).ok());
    const auto t0 = Clock::now();

    registry.session_closed(1, t0);

    EXPECT_TRUE(registry.expire(t0 + 1s).empty());
    EXPECT_TRUE(registry.lookup("/a").has_value());
    EXPECT_EQ(registry.expire(t0 + 2s), std::vector<std::string>{"/a"});
    EXPECT_FALSE(registry.lookup("/a").has_value());
}

TEST(Registry_test, ADaemonThatReconnectsWithinTheGracePeriodKeepsItsPorts) {
    Registry registry(2s);
    ASSERT_TRUE(registry.register_node("n1", "h:1", 1).ok());
    ASSERT_TRUE(registry.register_port("/a", 1).ok());
    const auto t0 = Clock::now();
    registry.session_closed(1, t0);

    ASSERT_TRUE(registry.register_node("n1", "h:1", 7).ok());

    EXPECT_TRUE(registry.expire(t0 + 10s).empty());
    EXPECT_TRUE(registry.lookup("/a").has_value());
}

TEST(Registry_test, UnregisteringAPortDropsItsLiveConnectionsButKeepsPersistentOnes) {
    Registry registry(2s);
    ASSERT_TRUE(registry.register_node("n1", "h:1", 1).ok());
    ASSERT_TRUE(registry.register_port("/a", 1).ok());
    ASSERT_TRUE(registry.register_port("/b", 1).ok());
    ASSERT_TRUE(registry.add_connection({"/a", "/b", "tcp", false}, 1).ok());
    ASSERT_TRUE(registry.add_connection({"/b", "/a", "tcp", true}, 1).ok());

    ASSERT_TRUE(registry.unregister_port("/a", 1).ok());

    auto list = registry.list();
    ASSERT_EQ(list["connections"].size(), 1u);
    EXPECT_EQ(list["connections"][0]["source"], "/b");
    EXPECT_EQ(list["connections"][0]["live"], false);
    EXPECT_EQ(registry.persistent_for("/a").size(), 1u);
}

TEST(Registry_test, OnlyTheNodeOfTheSourceChangesItsConnections) {
    Registry registry(2s);
    ASSERT_TRUE(registry.register_node("arm", "h:1", 1).ok());
    ASSERT_TRUE(registry.register_node("head", "h:2", 2).ok());
    ASSERT_TRUE(registry.register_port("/arm/out", 1).ok());
    ASSERT_TRUE(registry.register_port("/head/in", 2).ok());

    auto forged = registry.add_connection({"/arm/out", "/head/in", "tcp", true}, 2);
    ASSERT_FALSE(forged.ok());
    EXPECT_EQ(forged.error().message, "port /arm/out belongs to node 'arm', not 'head'");
    EXPECT_FALSE(registry.add_connection({"/nowhere", "/head/in", "tcp", false}, 2).ok());
    ASSERT_TRUE(registry.add_connection({"/arm/out", "/head/in", "tcp", true}, 1).ok());
    EXPECT_FALSE(registry.remove_connection("/arm/out", "/head/in", 2).ok());
    EXPECT_FALSE(registry.unregister_port("/arm/out", 2).ok());
    EXPECT_EQ(registry.list()["connections"].size(), 1u);
    EXPECT_TRUE(registry.remove_connection("/arm/out", "/head/in", 1).ok());
}

TEST(Registry_test, ListShowsEachConnectionsQos) {
    Registry registry(2s);
    ASSERT_TRUE(registry.register_node("n", "127.0.0.1:1", 1).ok());
    ASSERT_TRUE(registry.register_port("/a", 1).ok());
    ASSERT_TRUE(registry.register_port("/b", 1).ok());
    ASSERT_TRUE(registry.add_connection({"/a", "/b", "tcp+qos.dscp.46+qos.prio.7", false}, 1).ok());
    ASSERT_TRUE(registry.add_connection({"/b", "/a", "udp", false}, 1).ok());
    auto list = registry.list();
    ASSERT_EQ(list["connections"].size(), 2u);
    for (const auto& c : list["connections"]) {
        const bool marked = c["source"] == "/a";
        EXPECT_EQ(c["dscp"], marked ? 46 : 0) << c.dump();
        EXPECT_EQ(c["prio"], marked ? 7 : 0) << c.dump();
    }
}

TEST(Registry_test, AGoneDaemonsPortsGiveTheirMulticastGroupsBackOldestReusedFirst) {
    Registry registry(2s);
    // Three groups: 239.1.1.0 to .2 on port 5000.
    registry.set_mcast_range((239u << 24) | (1u << 16) | (1u << 8), 3, 5000);
    ASSERT_TRUE(registry.register_node("n1", "h:1", 1).ok());
    ASSERT_TRUE(registry.register_node("n2", "h:2", 2).ok());
    for (const char* port : {"/a", "/b", "/c"})
        ASSERT_TRUE(registry.register_port(port, 1).ok());
    ASSERT_TRUE(registry.register_port("/d", 2).ok());
    EXPECT_EQ(*registry.mcast_group("/a"), "239.1.1.0:5000");
    EXPECT_EQ(*registry.mcast_group("/b"), "239.1.1.1:5000");
    EXPECT_EQ(*registry.mcast_group("/c"), "239.1.1.2:5000");
    EXPECT_EQ(*registry.mcast_group("/a"), "239.1.1.0:5000");  // the same while the port stays
    auto none = registry.mcast_group("/d");
    ASSERT_FALSE(none.ok());
    EXPECT_NE(none.error().message.find("all 3 multicast groups"), std::string::npos) << none.error().message;

    // A port unregistered gives its group back, and so do the ports of a node whose grace ran out;
    // given back first, reused first.
    ASSERT_TRUE(registry.unregister_port("/b", 1).ok());
    EXPECT_EQ(*registry.mcast_group("/d"), "239.1.1.1:5000");
    const auto t0 = Clock::now();
    registry.session_closed(1, t0);
    registry.expire(t0 + 2s);  // /a and /c go
    ASSERT_TRUE(registry.register_node("n3", "h:3", 3).ok());
    ASSERT_TRUE(registry.register_port("/e", 3).ok());
    ASSERT_TRUE(registry.register_port("/f", 3).ok());
    EXPECT_EQ(*registry.mcast_group("/e"), "239.1.1.0:5000");
    EXPECT_EQ(*registry.mcast_group("/f"), "239.1.1.2:5000");
    EXPECT_FALSE(registry.mcast_group("/a").ok());  // gone with its node
}

}  // namespace
}  // namespace plexus::daemon::names
