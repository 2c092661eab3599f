#include "core/permissions.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

namespace plexus::daemon {
namespace {

using nlohmann::json;

Permissions parsed(const json& file) {
    auto permissions = Permissions::parse(file, "test.json");
    EXPECT_TRUE(permissions.ok()) << (permissions.ok() ? "" : permissions.error().message);
    return permissions.ok() ? std::move(*permissions) : Permissions{};
}

Principal node(const std::string& name) {
    return {.node = name};
}

TEST(Permissions_test, PortPatternsStarWithinASegmentAndDoubleStarAcrossThem) {
    EXPECT_TRUE(port_matches("/arm/cmd", "/arm/cmd"));
    EXPECT_FALSE(port_matches("/arm/cmd", "/arm/cmd2"));
    EXPECT_TRUE(port_matches("/arm/*", "/arm/cmd"));
    EXPECT_FALSE(port_matches("/arm/*", "/arm/joint/1"));
    EXPECT_FALSE(port_matches("/arm/*", "/arms"));
    EXPECT_TRUE(port_matches("/arm/**", "/arm/joint/1"));
    EXPECT_TRUE(port_matches("/**", "/anything/at/all"));
    EXPECT_TRUE(port_matches("/*/state", "/arm/state"));
    EXPECT_FALSE(port_matches("/*/state", "/arm/left/state"));
    EXPECT_TRUE(port_matches("/**/state", "/arm/left/state"));
    EXPECT_TRUE(port_matches("/cam*/image", "/camera/image"));
    EXPECT_FALSE(port_matches("/cam*/image", "/cam/era/image"));
    EXPECT_TRUE(node_matches("*", "anything"));
    EXPECT_TRUE(node_matches("teleop-*", "teleop-left"));
    EXPECT_FALSE(node_matches("teleop-*", "planner"));
}

TEST(Permissions_test, WhatNoRuleAllowsIsRefused) {
    const auto permissions = parsed(json::parse(R"({"rules": [
        {"nodes": ["arm"], "allow": ["open", "read", "write", "connect", "monitor"], "ports": ["/arm/**"]},
        {"nodes": ["planner"], "allow": ["write"], "ports": ["/arm/cmd"]},
        {"nodes": ["*"], "allow": ["read"], "ports": ["/arm/state"]},
        {"users": [1000], "allow": ["open", "connect"], "ports": ["/ui/*"]}]})"));
    EXPECT_TRUE(permissions.allows(node("arm"), Action::open, "/arm/joint/1"));
    EXPECT_TRUE(permissions.allows(node("planner"), Action::write, "/arm/cmd"));
    EXPECT_FALSE(permissions.allows(node("planner"), Action::monitor, "/arm/cmd"));
    EXPECT_FALSE(permissions.allows(node("intruder"), Action::write, "/arm/cmd"));
    EXPECT_TRUE(permissions.allows(node("intruder"), Action::read, "/arm/state"));
    EXPECT_FALSE(permissions.allows(node("intruder"), Action::read, "/arm/cmd"));
    EXPECT_TRUE(permissions.allows({.user = 1000}, Action::open, "/ui/panel"));
    EXPECT_FALSE(permissions.allows({.user = 1001}, Action::open, "/ui/panel"));
    EXPECT_FALSE(permissions.allows({.user = 1000}, Action::write, "/ui/panel"));
    // A user is not a node: a rule by node does not reach a local user, nor the other way round.
    EXPECT_FALSE(permissions.allows({.user = 1000}, Action::read, "/arm/state"));
    EXPECT_FALSE(permissions.allows(node("1000"), Action::open, "/ui/panel"));
    EXPECT_FALSE(permissions.allows(Principal{}, Action::read, "/arm/state"));
}

TEST(Permissions_test, AFileThatSaysSomethingElseIsRefusedWithWhereAndWhy) {
    const auto refused = [](const char* text, const std::string& expected) {
        auto permissions = Permissions::parse(json::parse(text), "perm.json");
        ASSERT_FALSE(permissions.ok()) << text;
        EXPECT_NE(permissions.error().message.find(expected), std::string::npos)
            << permissions.error().message;
    };
    refused(R"({"rule": []})", "perm.json: a permissions file is");
    refused(R"({"rules": [], "default": "allow"})", "unknown key \"default\"");
    refused(R"({"rules": [{"nodes": ["a"], "allow": ["wrtie"], "ports": ["/a"]}]})",
            "rule 1: unknown action \"wrtie\"");
    refused(R"({"rules": [{"allow": ["read"], "ports": ["/a"]}]})", "names no one");
    refused(R"({"rules": [{"nodes": ["a"], "allow": ["read"]}]})", "allows nothing");
    refused(R"({"rules": [{"nodes": "a", "allow": ["read"], "ports": ["/a"]}]})", "must be a list");
    refused(R"({"rules": [{"users": ["no-such-user-here"], "allow": ["read"], "ports": ["/a"]}]})",
            "no user named 'no-such-user-here'");
    refused(R"({"rules": [{"nodes": ["a"], "allow": ["read"], "ports": ["/a"], "deny": ["/b"]}]})",
            "unknown key \"deny\"");
}

TEST(Permissions_test, AUserMayBeNamed) {
    const auto permissions =
        parsed(json::parse(R"({"rules": [{"users": ["root"], "allow": ["open"], "ports": ["/x"]}]})"));
    EXPECT_TRUE(permissions.allows({.user = 0}, Action::open, "/x"));
}

}  // namespace
}  // namespace plexus::daemon
