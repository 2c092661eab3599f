// The bridges' command-line mappings and the mqtt --broker flag, checked at start.
#include <gtest/gtest.h>

#include "broker_address.hpp"
#include "mapping.hpp"

namespace plexus::bridge {
namespace {

TEST(Mapping_test, ParsesFromAndTo) {
    const auto mapping = parse_mapping("sensors/+/temp=/mqtt/temp", "--in", false);
    EXPECT_EQ(mapping.from, "sensors/+/temp");
    EXPECT_EQ(mapping.to, "/mqtt/temp");
    EXPECT_TRUE(mapping.type.empty());
}

TEST(Mapping_test, SplitsAtTheFirstEquals) {
    const auto mapping = parse_mapping("/robot/state=a=b", "--out", false);
    EXPECT_EQ(mapping.from, "/robot/state");
    EXPECT_EQ(mapping.to, "a=b");
}

TEST(Mapping_test, ParsesTheTypeAfterTheLastColon) {
    const auto mapping = parse_mapping("/chatter=/ros/chatter:std_msgs/msg/String", "--in", true);
    EXPECT_EQ(mapping.to, "/ros/chatter");
    EXPECT_EQ(mapping.type, "std_msgs/msg/String");
}

TEST(Mapping_test, RefusesMalformedMappingsNamingTheFlag) {
    for (const std::string bad : {"no-equals", "=/p", "a=", ""}) {
        try {
            parse_mapping(bad, "--in", false);
            ADD_FAILURE() << "accepted '" << bad << "'";
        } catch (const UsageError& error) {
            EXPECT_NE(std::string(error.what()).find("--in"), std::string::npos) << error.what();
        }
    }
    EXPECT_THROW(parse_mapping("/a=/b", "--in", true), UsageError);
    EXPECT_THROW(parse_mapping("/a=/b:", "--in", true), UsageError);
}

TEST(Mapping_test, PortNamesAreChecked) {
    EXPECT_NO_THROW(require_port("/mqtt/temp", "--in"));
    for (const std::string bad : {"mqtt", "/", "/a/", "/a//b", "/a b", "/a+b"})
        EXPECT_THROW(require_port(bad, "--in"), UsageError) << bad;
    EXPECT_THROW(require_distinct_ports({"/a", "/b", "/a"}, "mqtt"), UsageError);
    EXPECT_NO_THROW(require_distinct_ports({"/a", "/b"}, "mqtt"));
}

TEST(BrokerAddress_test, ParsesHostAndPort) {
    const auto address = parse_broker("localhost:1883");
    EXPECT_EQ(address.host, "localhost");
    EXPECT_EQ(address.port, 1883);
    const auto v6 = parse_broker("[::1]:8883");
    EXPECT_EQ(v6.host, "::1");
    EXPECT_EQ(v6.port, 8883);
}

TEST(BrokerAddress_test, RefusesWhatCannotBeABroker) {
    for (const std::string bad :
         {"localhost", ":1883", "host:", "host:0", "host:65536", "host:12x", "host:-1"})
        EXPECT_THROW(parse_broker(bad), UsageError) << bad;
}

}  // namespace
}  // namespace plexus::bridge
