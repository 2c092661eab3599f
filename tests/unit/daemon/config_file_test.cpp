// plexusd's config file (config_file.hpp): the keys it takes and what it refuses.
#include "config_file.hpp"

#include <stdexcept>

#include <gtest/gtest.h>

namespace plexus::daemon {
namespace {

TEST(ConfigFile_test, AppliesKnownKeysAndAllowsComments) {
    DaemonConfig config;
    apply_config_text("test.json", "{ // a comment\n \"max_frame\": 1048576, \"link_capacity\": 8 }",
                              config);
    EXPECT_EQ(config.max_frame, 1048576u);
    EXPECT_EQ(config.link_capacity, 8u);
}

TEST(ConfigFile_test, RefusesAnUnknownKey) {
    DaemonConfig config;
    EXPECT_THROW(apply_config_text("test.json", R"({"max_frames": 1})", config), std::runtime_error);
}

}  // namespace
}  // namespace plexus::daemon
