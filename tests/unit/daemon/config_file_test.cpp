// plexusd's config file (app/config_file.hpp): the keys it takes and what it refuses.
#include "app/config_file.hpp"

#include <string>
#include <utility>
#include <vector>

#include <stdexcept>

#include <gtest/gtest.h>

namespace plexus::daemon {
namespace {

TEST(ConfigFile_test, AppliesKnownKeysAndAllowsComments) {
    DaemonConfig config;
    apply_config_text("test.json", "{ // a comment\n \"max_frame\": 1048576, \"link_capacity\": 8 }", config);
    EXPECT_EQ(config.max_frame, 1048576u);
    EXPECT_EQ(config.link_capacity, 8u);
}

TEST(ConfigFile_test, HandshakeTimeoutIsTakenWithinItsBoundsAndRefusedOutside) {
    DaemonConfig config;
    EXPECT_EQ(config.handshake_timeout, std::chrono::milliseconds(10000));  // the default
    apply_config_text("test.json", R"({"handshake_timeout_ms": 250})", config);
    EXPECT_EQ(config.handshake_timeout, std::chrono::milliseconds(250));
    for (const char* text : {R"({"handshake_timeout_ms": 99})", R"({"handshake_timeout_ms": 3600001})"}) {
        try {
            apply_config_text("test.json", text, config);
            ADD_FAILURE() << "accepted " << text;
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find("handshake_timeout_ms must be between 100 and 3600000"),
                      std::string::npos)
                << e.what();
        }
    }
}

TEST(ConfigFile_test, PeerLimitsAreTakenWithinTheirBoundsAndTheHandshakesFollowFewerConnections) {
    DaemonConfig config;
    EXPECT_EQ(config.peer_limits.connections, 1024u);  // the defaults
    EXPECT_EQ(config.peer_limits.handshakes, 128u);
    EXPECT_EQ(config.peer_limits.failed_proofs, 10u);
    apply_config_text("test.json", R"({"peer_connections": 50, "peer_failed_proofs": 0})", config);
    EXPECT_EQ(config.peer_limits.connections, 50u);
    EXPECT_EQ(config.peer_limits.handshakes, 50u) << "at most as many handshakes as connections";
    EXPECT_EQ(config.peer_limits.failed_proofs, 0u);
    for (const auto& [text, why] : std::vector<std::pair<std::string, std::string>>{
             {R"({"peer_connections": 0})", "peer_connections must be between 1 and 1000000"},
             {R"({"peer_connections": 10, "peer_handshakes": 11})", "peer_handshakes must be between 1 and"},
             {R"({"peer_handshakes": 0})", "peer_handshakes must be between 1 and"},
             {R"({"peer_failed_proofs": 1001})", "peer_failed_proofs must be between 0 (no limit) and 1000"},
             {R"({"peer_connections": -1})", "peer_connections must be a whole number"}}) {
        DaemonConfig fresh;
        try {
            apply_config_text("test.json", text, fresh);
            ADD_FAILURE() << "accepted " << text;
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find(why), std::string::npos) << e.what();
        }
    }
}

TEST(ConfigFile_test, RingSizesArePowersOfTwoInBoundsOrZeroAndTheSpinIsBounded) {
    DaemonConfig config;
    EXPECT_EQ(config.shm_ring_bytes, 512u * 1024u);  // the default
    EXPECT_EQ(config.ring_spin.count(), 0);
    apply_config_text("test.json", R"({"shm_ring_bytes": 65536, "shm_ring_spin_us": 20})", config);
    EXPECT_EQ(config.shm_ring_bytes, 65536u);
    EXPECT_EQ(config.ring_spin, std::chrono::microseconds(20));
    apply_config_text("test.json", R"({"shm_ring_bytes": 0})", config);
    EXPECT_EQ(config.shm_ring_bytes, 0u);
    for (const char* text : {R"({"shm_ring_bytes": 100000})", R"({"shm_ring_bytes": 32768})",
                             R"({"shm_ring_bytes": 33554432})"}) {
        EXPECT_THROW(apply_config_text("test.json", text, config), std::runtime_error) << text;
    }
    EXPECT_THROW(apply_config_text("test.json", R"({"shm_ring_spin_us": 1001})", config), std::runtime_error);
}

TEST(ConfigFile_test, MonitorInlineCostIsTakenZeroTurnsInlineOffAndTooMuchIsRefused) {
    DaemonConfig config;
    EXPECT_EQ(config.monitors.inline_cost_limit, std::chrono::microseconds(10));  // the default
    apply_config_text("test.json", R"({"monitor_inline_cost_us": 0})", config);
    EXPECT_EQ(config.monitors.inline_cost_limit.count(), 0);
    apply_config_text("test.json", R"({"monitor_inline_cost_us": 1000000})", config);
    EXPECT_EQ(config.monitors.inline_cost_limit, std::chrono::seconds(1));
    try {
        apply_config_text("test.json", R"({"monitor_inline_cost_us": 1000001})", config);
        ADD_FAILURE() << "accepted 1000001";
    } catch (const std::runtime_error& e) {
        EXPECT_NE(std::string(e.what()).find("monitor_inline_cost_us must be at most 1000000"),
                  std::string::npos)
            << e.what();
    }
}

TEST(ConfigFile_test, RefusesAnUnknownKey) {
    DaemonConfig config;
    EXPECT_THROW(apply_config_text("test.json", R"({"max_frames": 1})", config), std::runtime_error);
}

// Found by tests/fuzz/daemon_config_fuzz.cpp: json.value() converted any number to the setting's
// type, so 1e300 was undefined behaviour (UBSan: "outside the range of representable values"),
// -1 a max_frame of 16 EiB and 4294967297 a quarantine after 1 failure.
TEST(ConfigFile_test, RefusesANumberThatIsNotAWholeNumberInRange) {
    for (const char* text : {R"({"max_frame": 1e300})", R"({"monitor_budget_ms": 1e300})",
                             R"({"max_frame": -1})", R"({"monitor_quarantine_after": 4294967297})",
                             R"({"monitor_budget_ms": 20.5})", R"({"udp_timeout_ms": "100"})"}) {
        DaemonConfig config;
        try {
            apply_config_text("test.json", text, config);
            ADD_FAILURE() << "accepted " << text;
        } catch (const std::runtime_error& e) {
            EXPECT_NE(std::string(e.what()).find("must be a whole number from"), std::string::npos)
                << e.what();
        }
    }
}

TEST(ConfigFile_test, RefusesAFileThatIsNotAnObject) {
    DaemonConfig config;
    EXPECT_THROW(apply_config_text("test.json", "null", config), std::runtime_error);
}

}  // namespace
}  // namespace plexus::daemon
