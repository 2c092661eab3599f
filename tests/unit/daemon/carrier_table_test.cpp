// The carrier table: one entry per base carrier that carrier strings accept, found by name, a clear
// error for any other; and the sending ends that need no peer daemon (local's, udp's stats).
#include "net/carriers/carrier_table.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

#include <nlohmann/json.hpp>

#include "arbitration/arbiter.hpp"
#include "arbitration/clock.hpp"
#include "core/inlet.hpp"
#include "core/port.hpp"
#include "net/carriers/udp.hpp"
#include "plexus/proto/carrier.hpp"
#include "test_messages.hpp"

namespace plexus::daemon::carriers {
namespace {

/// What a carrier may ask of the daemon, with a UDP socket of its own on loopback.
class TestHost : public CarrierHost {
public:
    const NetConfig& config() const override { return config_; }
    UdpSocket& udp() override { return udp_; }
    Task<proto::Result<std::string>> mcast_group(std::string source) override {
        co_return proto::Error{"no group for " + source};
    }

    asio::io_context io;

private:
    NetConfig config_;
    UdpSocket udp_{io, UdpConfig{}};
};

TEST(CarrierTable_test, HasOneEntryForEachBaseCarrierStringsAccept) {
    // proto::CarrierSupport is what clients check carrier strings against: a carrier in one list
    // and not the other would pass `plexus check` and fail connect, or the reverse.
    const proto::CarrierSupport support;
    std::vector<std::string> table;
    for (auto name : carrier_names())
        table.emplace_back(name);
    EXPECT_EQ(table, support.bases);
    for (const auto& base : support.bases) {
        auto found = find_carrier(base);
        ASSERT_TRUE(found.ok()) << base;
        EXPECT_EQ((*found)->name(), base);
    }
}

TEST(CarrierTable_test, RefusesAnUnknownBaseNamingItAndTheKnownOnes) {
    auto found = find_carrier("pigeon");
    ASSERT_FALSE(found.ok());
    EXPECT_EQ(found.error().message, "unknown carrier 'pigeon' (this daemon knows tcp, udp, mcast, local)");
    EXPECT_FALSE(find_carrier("").ok());
    EXPECT_FALSE(find_carrier("TCP").ok());
}

TEST(CarrierTable_test, OnlyLocalStaysWithinTheDaemon) {
    for (auto name : carrier_names())
        EXPECT_EQ((*find_carrier(name))->within_daemon(), name == "local") << name;
}

TEST(CarrierTable_test, AConnectNamingNoCarrierStaysInTheDaemonWhenItCanElseTakesTcp) {
    EXPECT_EQ(automatic_carrier(true).name(), "local");
    EXPECT_EQ(automatic_carrier(false).name(), "tcp");
}

TEST(CarrierTable_test, LocalSendingEndIsTheDestinationsInletAndReportsNothing) {
    TestHost host;
    arbitration::ManualClock clock;
    auto arbiter = std::make_shared<arbitration::Arbiter>(clock);
    auto port = std::make_shared<Port>("/b", 1, QueuePolicy::strict, 4);
    auto inlet =
        std::make_shared<Inlet>(port, "/a", "local", std::make_shared<arbitration::Member>(arbiter, "/a"));
    SendingContext context{.host = host,
                           .request = {},
                           .carrier = {},
                           .link = nullptr,
                           .endpoint = {},
                           .attached = {},
                           .inlet = inlet,
                           .connection = std::make_shared<Connection>(),
                           .make_send_stage = {}};

    auto end = (*find_carrier("local"))->make_sending_end(context);

    ASSERT_TRUE(end.ok()) << end.error().message;
    EXPECT_EQ(end->sink, inlet);
    EXPECT_EQ(end->send_monitors, nullptr);  // the connection has no send-side monitors
    EXPECT_EQ(end->queue, nullptr);          // nothing waits between the ports
    nlohmann::json entry = nlohmann::json::object();
    end->sink->report_stats(entry);
    EXPECT_TRUE(entry.empty());
    EXPECT_EQ(end->sink->shared_send_stage(), nullptr);
}

TEST(CarrierTable_test, LocalRefusesWithoutAnInlet) {
    TestHost host;
    SendingContext context{.host = host,
                           .request = {},
                           .carrier = {},
                           .link = nullptr,
                           .endpoint = {},
                           .attached = {},
                           .inlet = nullptr,
                           .connection = std::make_shared<Connection>(),
                           .make_send_stage = {}};
    EXPECT_FALSE((*find_carrier("local"))->make_sending_end(context).ok());
}

TEST(CarrierTable_test, UdpSendingEndReportsItsOwnCountersInStats) {
    TestHost host;
    ASSERT_TRUE(host.udp().bind(asio::ip::make_address("127.0.0.1"), 0).ok());
    const asio::ip::udp::endpoint nowhere(asio::ip::make_address("127.0.0.1"), host.udp().port());
    UdpLink link(host.udp(), nowhere, 7, nullptr, "connection /a -> /b");

    link.deliver(test::batch_of(3, "/a", [](std::uint32_t seq) { return nlohmann::json::to_cbor(seq); }));

    nlohmann::json entry = nlohmann::json::object();
    link.report_stats(entry);
    ASSERT_TRUE(entry.contains("udp"));
    EXPECT_EQ(entry["udp"]["messages"], 3);
    EXPECT_EQ(entry["udp"]["datagrams"], 3);
    EXPECT_EQ(entry["udp"]["dropped_too_large"], 0);
    EXPECT_EQ(entry["udp"]["dropped_send"], 0);
    EXPECT_FALSE(link.full());
    EXPECT_EQ(link.room(), never_full_room);
}

}  // namespace
}  // namespace plexus::daemon::carriers
