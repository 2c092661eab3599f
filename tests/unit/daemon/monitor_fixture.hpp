#pragma once
// What the tests of Lua monitors in isolation share: a fake host, a policy with small limits, a
// spec for a script given as text, and a fixture that makes monitors from such scripts.

#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "monitor/monitor.hpp"
#include "test_messages.hpp"

namespace plexus::daemon::monitor {

using namespace std::chrono_literals;
using nlohmann::json;

class FakeHost : public MonitorHost {
public:
    proto::Status publish(Monitor&, const std::string& port, const json& value) override {
        if (port.empty() || port[0] != '/')
            return proto::Error{"port names start with '/'"};
        published.emplace_back(port, value);
        return proto::Ok{};
    }
    void set_trig_interval(Monitor&, double seconds) override { trig_interval = seconds; }
    double now() const override { return clock; }
    void monitor_gone(Monitor&) override { ++gone; }

    std::vector<std::pair<std::string, json>> published;
    double trig_interval = -1;
    double clock = 1000.0;
    int gone = 0;
};

inline MonitorPolicy test_policy() {
    MonitorPolicy policy;
    policy.limits.memory_bytes = 4u * 1024u * 1024u;
    policy.limits.budget = 50ms;
    policy.quarantine_after = 3;
    return policy;
}

inline MonitorSpec spec_for(const std::string& code, std::map<std::string, std::string> options = {}) {
    MonitorSpec spec;
    spec.script = Script{"test", "test.lua", code};
    spec.side = proto::Side::recv;
    spec.source = "/a";
    spec.destination = "/b";
    spec.carrier = "tcp+recv.portmonitor+file.test";
    spec.options = std::move(options);
    return spec;
}

inline Message make_message(const json& payload, std::uint64_t seq = 7) {
    return daemon::test::json_message(payload, seq);
}

using daemon::test::payload_of;

struct Fixture : ::testing::Test {
    FakeHost host;
    std::unique_ptr<Monitor> make(const std::string& code, std::map<std::string, std::string> options = {}) {
        auto created = Monitor::create(spec_for(code, std::move(options)), test_policy(), host);
        EXPECT_TRUE(created.ok()) << (created.ok() ? "" : created.error().message);
        return created.ok() ? std::move(*created) : nullptr;
    }
    std::string refusal(const std::string& code) {
        auto created = Monitor::create(spec_for(code), test_policy(), host);
        EXPECT_FALSE(created.ok());
        return created.ok() ? std::string() : created.error().message;
    }
};

}  // namespace plexus::daemon::monitor
