#include "names/reachable_address.hpp"

#include <gtest/gtest.h>

namespace plexus::daemon::names {
namespace {

asio::ip::address ip(const char* text) {
    return asio::ip::make_address(text);
}

TEST(ReachableAddress_test, AWildcardHostIsRecordedAtTheAddressTheSessionCameFrom) {
    const SessionAddresses daemon{ip("10.1.0.7"), ip("10.1.0.1")};
    EXPECT_EQ(recorded_address("0.0.0.0:4000", daemon), "10.1.0.7:4000");
    EXPECT_EQ(recorded_address("[::]:4000", SessionAddresses{ip("fd00::7"), ip("fd00::1")}),
              "[fd00::7]:4000");
}

TEST(ReachableAddress_test, ASpecificHostIsRecordedAsAnnounced) {
    const SessionAddresses daemon{ip("10.1.0.7"), ip("10.1.0.1")};
    EXPECT_EQ(recorded_address("10.2.0.9:4000", daemon), "10.2.0.9:4000");
    EXPECT_EQ(recorded_address("robot.local:4000", daemon), "robot.local:4000");
    EXPECT_EQ(recorded_address("0.0.0.0:4000", SessionAddresses{}), "0.0.0.0:4000");  // no session: as is
}

TEST(ReachableAddress_test, ALoopbackDaemonIsGivenToAnotherHostAtTheAddressItReachedTheNameServerAt) {
    const SessionAddresses remote_asker{ip("10.1.0.7"), ip("10.1.0.1")};
    EXPECT_EQ(address_for("127.0.0.1:4000", remote_asker), "10.1.0.1:4000");
    const SessionAddresses local_asker{ip("127.0.0.1"), ip("127.0.0.1")};
    EXPECT_EQ(address_for("127.0.0.1:4000", local_asker), "127.0.0.1:4000");
    EXPECT_EQ(address_for("127.0.0.1:4000", SessionAddresses{}), "127.0.0.1:4000");  // UDP: as recorded
    EXPECT_EQ(address_for("10.3.0.2:4000", remote_asker), "10.3.0.2:4000");
}

}  // namespace
}  // namespace plexus::daemon::names
