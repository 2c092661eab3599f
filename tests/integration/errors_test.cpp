// Wrong input from a user gets the contract's exit status and a message that says what is wrong.
#include <gtest/gtest.h>

#include "harness.hpp"

namespace plexus::test {
namespace errors_test {

class Errors_test : public ::testing::Test {
protected:
    TempDir dir;
    Daemon daemon{dir, "solo"};
    CliResult cli(const std::vector<std::string>& args) { return run_cli(dir, daemon, args); }
};

TEST_F(Errors_test, ConnectingPortsThatDoNotExistIsRefused) {
    auto result = cli({"connect", "/nobody", "/nowhere"});
    EXPECT_EQ(result.status, 4);
    EXPECT_NE(result.err.find("/nobody does not exist"), std::string::npos) << result.err;
}

TEST_F(Errors_test, ConnectingToAMissingDestinationIsRefused) {
    auto holder = start_cli(dir, daemon, {"read", "/here", "--timeout", "30"}, "holder");
    ASSERT_TRUE(wait_port(dir, daemon, "/here"));
    auto result = cli({"connect", "/here", "/nowhere"});
    EXPECT_EQ(result.status, 4);
    EXPECT_NE(result.err.find("/nowhere does not exist"), std::string::npos) << result.err;
}

TEST_F(Errors_test, AnUnknownCarrierIsRefusedNamingIt) {
    auto result = cli({"connect", "/a", "/b", "carrier-pigeon"});
    EXPECT_EQ(result.status, 4);
    EXPECT_NE(result.err.find("carrier-pigeon"), std::string::npos) << result.err;
}

TEST_F(Errors_test, AnUnknownModifierIsRefusedNamingIt) {
    auto result = cli({"connect", "/a", "/b", "tcp+recv.bogus"});
    EXPECT_EQ(result.status, 4);
    EXPECT_NE(result.err.find("recv.bogus"), std::string::npos) << result.err;
}

TEST_F(Errors_test, AnInvalidPortNameIsAUsageErrorNamingTheRule) {
    auto result = cli({"read", "no-slash", "--timeout", "1"});
    EXPECT_EQ(result.status, 2);
    EXPECT_NE(result.err.find("must start with '/'"), std::string::npos) << result.err;
    result = cli({"exists", "/double//slash"});
    EXPECT_EQ(result.status, 2);
    EXPECT_NE(result.err.find("//"), std::string::npos) << result.err;
}

TEST_F(Errors_test, TwoPortsWithTheSameNameAreRefused) {
    auto first = start_cli(dir, daemon, {"read", "/twice", "--timeout", "30"}, "first");
    ASSERT_TRUE(wait_port(dir, daemon, "/twice"));
    auto second = cli({"read", "/twice", "--timeout", "1"});
    EXPECT_EQ(second.status, 4);
    EXPECT_NE(second.err.find("already"), std::string::npos) << second.err;
}

TEST_F(Errors_test, TheSameNameOnAnotherDaemonIsRefusedByTheNameServer) {
    Daemon other(dir, "other", daemon.names());
    auto first = start_cli(dir, daemon, {"read", "/twice", "--timeout", "30"}, "first");
    ASSERT_TRUE(wait_port(dir, daemon, "/twice"));
    auto second = run_cli(dir, other, {"read", "/twice", "--timeout", "1"});
    EXPECT_EQ(second.status, 4);
    EXPECT_NE(second.err.find("already exists on node 'solo'"), std::string::npos) << second.err;
}

TEST_F(Errors_test, NoDaemonIsReportedWithWhereItWasLookedFor) {
    auto result = run_cli(dir, daemon, {"--socket", dir.file("missing.sock"), "stats"});
    EXPECT_EQ(result.status, 4);
    EXPECT_NE(result.err.find(dir.file("missing.sock")), std::string::npos) << result.err;
}

TEST_F(Errors_test, MissingArgumentsAreUsageErrors) {
    EXPECT_EQ(cli({"connect"}).status, 2);
    EXPECT_EQ(cli({"frobnicate"}).status, 2);
    EXPECT_EQ(cli({"read", "/x", "--count", "-3"}).status, 2);
}

TEST_F(Errors_test, ExistsAnswersYesAndNo) {
    EXPECT_EQ(cli({"exists", "/absent"}).status, 1);
    auto holder = start_cli(dir, daemon, {"read", "/present", "--timeout", "30"}, "holder");
    ASSERT_TRUE(wait_port(dir, daemon, "/present"));
    EXPECT_EQ(cli({"exists", "/present"}).status, 0);
    EXPECT_EQ(cli({"exists", "/present", "/absent"}).status, 1);
}

TEST_F(Errors_test, WaitTimesOutWithStatusThree) {
    EXPECT_EQ(cli({"wait", "/never", "--timeout", "0.2"}).status, 3);
}

TEST_F(Errors_test, ReadTimesOutWithStatusThree) {
    auto result = cli({"read", "/quiet", "--count", "1", "--timeout", "0.2"});
    EXPECT_EQ(result.status, 3);
}

TEST_F(Errors_test, DisconnectingWhatIsNotConnectedIsANoAnswer) {
    auto holder = start_cli(dir, daemon, {"read", "/a", "--timeout", "30"}, "holder");
    ASSERT_TRUE(wait_port(dir, daemon, "/a"));
    EXPECT_EQ(cli({"disconnect", "/a", "/b"}).status, 1);
}

}  // namespace errors_test
}  // namespace plexus::test
