#include "names/state_file.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace plexus::daemon::names {
namespace {

/// A directory of its own under the system's temporary directory, removed at the end.
struct Directory {
    std::filesystem::path path;
    Directory() {
        path = std::filesystem::temp_directory_path() /
               ("plexus-state-test-" + std::to_string(::getpid()) + "-" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        std::filesystem::remove_all(path);
        std::filesystem::create_directories(path);
    }
    ~Directory() { std::filesystem::remove_all(path); }
    std::string file(const std::string& name) const { return (path / name).string(); }
};

void write_raw(const std::string& path, const std::string& text) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}

std::string read_raw(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::stringstream whole;
    whole << in.rdbuf();
    return whole.str();
}

const std::vector<ConnectionEntry> two{{"/a", "/b", "tcp", true}, {"/c", "/d", "udp+qos.dscp.46", true}};

TEST(StateFile_test, WritesDurablyAndReadsBackWithoutATemporaryLeft) {
    Directory dir;
    const auto path = dir.file("state.json");
    ASSERT_TRUE(write_durably(path, state_text(two)).ok());
    EXPECT_FALSE(std::filesystem::exists(path + ".tmp"));
    const auto read = read_state(path);
    EXPECT_TRUE(read.problems.empty());
    ASSERT_EQ(read.persistent.size(), 2u);
    EXPECT_EQ(read.persistent[1].source, "/c");
    EXPECT_EQ(read.persistent[1].carrier, "udp+qos.dscp.46");
    EXPECT_TRUE(read.persistent[1].persistent);
    // Replacing it leaves the new text whole.
    ASSERT_TRUE(write_durably(path, state_text({two[0]})).ok());
    EXPECT_EQ(read_raw(path), state_text({two[0]}));
}

TEST(StateFile_test, AMissingFileIsAnEmptyStateAndNoProblem) {
    Directory dir;
    const auto read = read_state(dir.file("none.json"));
    EXPECT_TRUE(read.problems.empty());
    EXPECT_TRUE(read.persistent.empty());
}

TEST(StateFile_test, AnEmptyFileIsReportedAndReadsAsEmpty) {
    Directory dir;
    const auto path = dir.file("state.json");
    for (const std::string empty : {"", "\n  \n"}) {
        write_raw(path, empty);
        const auto read = read_state(path);
        EXPECT_TRUE(read.persistent.empty());
        ASSERT_EQ(read.problems.size(), 1u);
        EXPECT_NE(read.problems[0].find(path + " is empty"), std::string::npos) << read.problems[0];
    }
}

TEST(StateFile_test, EveryTruncationIsReportedAndNeverInventsEntries) {
    Directory dir;
    const auto path = dir.file("state.json");
    const std::string whole = state_text(two);
    // Every cut short of the whole text (a cut that only loses the final newline is still whole).
    for (std::size_t size = 1; size + 1 < whole.size(); ++size) {
        write_raw(path, whole.substr(0, size));
        const auto read = read_state(path);
        EXPECT_EQ(read.problems.size(), 1u) << "cut at " << size;
        EXPECT_TRUE(read.persistent.empty()) << "cut at " << size;
    }
}

TEST(StateFile_test, BadEntriesAreSkippedAndTheGoodOnesKept) {
    Directory dir;
    const auto path = dir.file("state.json");
    write_raw(path, R"({"persistent": [{"source": "/a", "destination": "/b", "carrier": "tcp"},
                                       {"source": "/x"}, 7,
                                       {"source": "/c", "destination": "/d", "carrier": "udp"}]})");
    const auto read = read_state(path);
    ASSERT_EQ(read.persistent.size(), 2u);
    EXPECT_EQ(read.persistent[1].destination, "/d");
    ASSERT_EQ(read.problems.size(), 2u);
    EXPECT_NE(read.problems[0].find("persistent entry 1 is not {source, destination, carrier}"),
              std::string::npos)
        << read.problems[0];
    write_raw(path, R"({"something": []})");
    EXPECT_EQ(read_state(path).problems.size(), 1u);
}

TEST(StateFile_test, AWriteThatCannotHappenSaysWhichStepFailed) {
    Directory dir;
    const auto path = dir.file("missing-directory/state.json");
    const auto written = write_durably(path, "{}");
    ASSERT_FALSE(written.ok());
    EXPECT_NE(written.error().message.find("cannot create " + path + ".tmp"), std::string::npos)
        << written.error().message;
}

}  // namespace
}  // namespace plexus::daemon::names
