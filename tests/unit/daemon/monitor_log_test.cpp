// What a monitor says: its print lines in the daemon's log, caught by a test sink on spdlog's
// default logger, and the reason a refusing create gives reaching the connect's error.
#include <gtest/gtest.h>

#include <memory>
#include <sstream>
#include <string>

#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include "monitor_fixture.hpp"

namespace plexus::daemon::monitor {
namespace {

/// Replaces spdlog's default logger for the test's life with one that writes bare lines to `lines`.
class LogCapture {
public:
    LogCapture() : previous_(spdlog::default_logger()) {
        auto sink = std::make_shared<spdlog::sinks::ostream_sink_st>(lines_);
        sink->set_pattern("%v");
        auto logger = std::make_shared<spdlog::logger>("capture", sink);
        logger->set_level(spdlog::level::trace);
        spdlog::set_default_logger(logger);
    }
    ~LogCapture() { spdlog::set_default_logger(previous_); }
    LogCapture(const LogCapture&) = delete;
    LogCapture& operator=(const LogCapture&) = delete;

    std::string text() const { return lines_.str(); }

private:
    std::shared_ptr<spdlog::logger> previous_;
    std::ostringstream lines_;
};

using MonitorLog_test = Fixture;

TEST_F(MonitorLog_test, PrintLogsItsArgumentsTabSeparatedAndNothingElse) {
    LogCapture log;
    auto monitor = make(R"(PortMonitor.create = function() print("a", 1, true) return true end)");
    ASSERT_TRUE(monitor);
    // Lua's own print separates with tabs; the line is tagged with the monitor's description.
    EXPECT_NE(log.text().find("[test (recv /a -> /b)] a\t1\ttrue\n"), std::string::npos) << log.text();
    EXPECT_EQ(log.text().find("userdata"), std::string::npos) << log.text();
}

TEST_F(MonitorLog_test, PrintWithoutArgumentsLogsAnEmptyLine) {
    LogCapture log;
    auto monitor = make(R"(PortMonitor.create = function() print() return true end)");
    ASSERT_TRUE(monitor);
    EXPECT_NE(log.text().find("[test (recv /a -> /b)] \n"), std::string::npos) << log.text();
}

}  // namespace
}  // namespace plexus::daemon::monitor
