// The directory of plexusd's Unix socket (app/socket_directory.hpp): whoever may write in it may
// put a socket of their own in its place, so plexusd makes it 0700 and refuses one that belongs to
// another user or that its group or others may write, with exit 4 and a line that says why.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <optional>
#include <string>

#include "harness.hpp"
#include "plexus/client.hpp"

namespace plexus::test {
namespace socket_directory_test {

/// plexusd with its socket at `socket` and a name server of its own on free ports: one that
/// wrongly starts serves nobody else, and is killed with the Process.
Process start_plexusd(const TempDir& dir, const std::string& socket, const std::string& name) {
    return Process({plexusd_path(), "--embedded-names", "--names", "127.0.0.1:0", "--listen", "127.0.0.1:0",
                    "--socket", socket, "--node", name, "--ready-file", dir.file(name + ".ready")},
                   {}, dir.file(name));
}

struct Outcome {
    std::optional<int> status;  ///< nullopt: still running at the deadline
    std::string log;            ///< stdout and stderr
};

Outcome refused(const TempDir& dir, const std::string& socket, const std::string& name) {
    auto process = start_plexusd(dir, socket, name);
    const auto status = process.wait(10s);
    return {status, process.out() + process.err()};
}

/// Starts plexusd and waits until it serves; false (with its log) if it did not.
bool serves(const TempDir& dir, Process& process, const std::string& name) {
    if (eventually([&] { return std::filesystem::exists(dir.file(name + ".ready")); }))
        return true;
    ADD_FAILURE() << "plexusd did not start: " << process.out() << process.err();
    return false;
}

mode_t mode_of(const std::string& path) {
    struct stat status {};
    EXPECT_EQ(::stat(path.c_str(), &status), 0) << path;
    return status.st_mode & 07777;
}

TEST(SocketDirectory_test, AMissingDirectoryIsMadeForTheDaemonsUserAlone) {
    TempDir dir;
    const std::string socket_dir = dir.file("made/here");
    auto daemon = start_plexusd(dir, socket_dir + "/plexusd.sock", "made");
    ASSERT_TRUE(serves(dir, daemon, "made"));
    EXPECT_EQ(mode_of(socket_dir), 0700u);
    Client client({socket_dir + "/plexusd.sock"});
    EXPECT_NO_THROW(client.open("/hygiene/port"));
}

TEST(SocketDirectory_test, ADirectoryOfAnotherUserIsRefused) {
    TempDir dir;
    std::string theirs;
    if (::geteuid() == 0) {  // as root (CI): a directory given to nobody (65534)
        theirs = dir.file("theirs");
        ASSERT_EQ(::mkdir(theirs.c_str(), 0755), 0);
        ASSERT_EQ(::chown(theirs.c_str(), 65534, 65534), 0);
    } else {
        theirs = "/usr";  // root's; the check comes before any attempt to write there
    }
    const auto outcome = refused(dir, theirs + "/plexusd.sock", "theirs");
    EXPECT_EQ(outcome.status, std::optional<int>(4)) << outcome.log;
    EXPECT_NE(outcome.log.find("belongs to uid"), std::string::npos) << outcome.log;
    EXPECT_NE(outcome.log.find("not to this daemon's user"), std::string::npos) << outcome.log;
}

TEST(SocketDirectory_test, ADirectoryOthersMayWriteIsRefused) {
    TempDir dir;
    for (const mode_t mode : {mode_t{0777}, mode_t{0770}, mode_t{01777}}) {
        SCOPED_TRACE(mode);
        const std::string open_dir = dir.file("open" + std::to_string(mode));
        ASSERT_EQ(::mkdir(open_dir.c_str(), 0700), 0);
        ASSERT_EQ(::chmod(open_dir.c_str(), mode), 0);  // chmod: mkdir's mode loses the umask's bits
        const auto outcome = refused(dir, open_dir + "/plexusd.sock", "open" + std::to_string(mode));
        EXPECT_EQ(outcome.status, std::optional<int>(4)) << outcome.log;
        EXPECT_NE(outcome.log.find("may be written by"), std::string::npos) << outcome.log;
        EXPECT_FALSE(std::filesystem::exists(open_dir + "/plexusd.sock")) << "the socket was made anyway";
    }
}

TEST(SocketDirectory_test, AGroupThatMayOnlyReadIsAllowed) {
    // The packaged service's /run/plexus is 0750: members of group plexus connect, nobody writes.
    TempDir dir;
    const std::string shared = dir.file("shared");
    ASSERT_EQ(::mkdir(shared.c_str(), 0700), 0);
    ASSERT_EQ(::chmod(shared.c_str(), 0750), 0);
    auto daemon = start_plexusd(dir, shared + "/plexusd.sock", "shared");
    ASSERT_TRUE(serves(dir, daemon, "shared"));
    Client client({shared + "/plexusd.sock"});
    EXPECT_NO_THROW(client.open("/hygiene/port"));
    EXPECT_EQ(mode_of(shared), 0750u) << "the daemon changed a directory it was given";
}

}  // namespace socket_directory_test
}  // namespace plexus::test
