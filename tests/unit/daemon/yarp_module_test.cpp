#include "monitor/yarp_module.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "monitor/lua_sandbox.hpp"

namespace plexus::daemon::monitor {
namespace {

/// A sandbox whose log lines are kept, with a PortMonitor.now that returns 42.5.
struct Script {
    std::vector<std::string> log;
    LuaSandbox sandbox{SandboxLimits{}, [this](std::string_view line) { log.emplace_back(line); }};
    Script() {
        const auto defined = sandbox.load("PortMonitor = { now = function() return 42.5 end }", "=setup");
        EXPECT_TRUE(defined.ok());
    }
    /// Runs `code`; the error's message, or "" when it ran.
    std::string run(const std::string& code) {
        const auto ran = sandbox.load(code, "=test");
        return ran ? "" : ran.error().message;
    }
};

TEST(YarpModule_test, RequireYarpGivesTimeAndALogAndTheGlobal) {
    Script script;
    ASSERT_EQ(script.run(R"(
        local y = require("yarp")
        assert(y == yarp, "require also sets the global yarp, as YARP's binding does")
        assert(require("yarp") == y, "the same module every time")
        assert(yarp.Time_now() == 42.5, "Time_now is the monitor's clock")
        yarp.log("hello", 1)
    )"),
              "");
    ASSERT_EQ(script.log.size(), 1u);
    // rfind(.., 0): the line starts with the arguments. (The sandbox's print adds a stray
    // "userdata: 0x..." after them today: its luaL_Buffer placeholder is counted as an argument.)
    EXPECT_EQ(script.log[0].rfind("hello\t1", 0), 0u) << script.log[0];
}

TEST(YarpModule_test, AnythingElseWarnsOncePerNameAndReturnsNil) {
    Script script;
    ASSERT_EQ(script.run(R"(
        require("yarp")
        assert(yarp.Bottle() == nil)
        yarp.Bottle()
        yarp.Time_delay(1.0)
    )"),
              "");
    ASSERT_EQ(script.log.size(), 2u);
    EXPECT_NE(script.log[0].find("yarp.Bottle is not available in Plexus"), std::string::npos)
        << script.log[0];
    EXPECT_NE(script.log[1].find("yarp.Time_delay is not available"), std::string::npos) << script.log[1];
    EXPECT_NE(script.run("require('yarp'); yarp.Time_now = nil").find("read-only"), std::string::npos);
}

TEST(YarpModule_test, EveryOtherModuleIsRefusedSayingWhy) {
    Script script;
    for (const std::string name : {"os", "io", "yarp.core", "YARP", "debug", ""}) {
        const auto error = script.run("require('" + name + "')");
        EXPECT_NE(
            error.find("require('" + name + "'): monitor scripts have no modules; only require(\"yarp\")"),
            std::string::npos)
            << error;
    }
    EXPECT_NE(script.run("require()").find("bad argument #1 to 'require'"), std::string::npos);
}

}  // namespace
}  // namespace plexus::daemon::monitor
