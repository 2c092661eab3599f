// What `plexus` says to a newcomer who mistypes a command or asks how to write a carrier
// (issue 26, defect 9).
#include <gtest/gtest.h>

#include <chrono>
#include <string>

#include "../../common/slowdown.hpp"
#include "command_line.hpp"
#include "run_program.hpp"

namespace plexus::test {
namespace {

using namespace std::chrono_literals;

ProgramResult plexus(std::vector<std::string> args) {
    args.insert(args.begin(), PLEXUS_CLI_PATH);
    return run_program(args, slower(5s));
}

TEST(CommandErrors_test, UnknownCommandIsNamedWithTheValidOnes) {
    const auto result = plexus({"nosuch"});
    EXPECT_EQ(result.exit_code, 2);
    EXPECT_NE(result.err.find("unknown command 'nosuch'"), std::string::npos) << result.err;
    for (const char* command : {"connect", "read", "write", "events", "up"})
        EXPECT_NE(result.err.find(command), std::string::npos) << command << " not listed: " << result.err;
}

TEST(CommandErrors_test, UnknownSubcommandOfParamListsGetAndSet) {
    const auto result = plexus({"param", "nosuch"});
    EXPECT_EQ(result.exit_code, 2);
    EXPECT_NE(result.err.find("plexus param: unknown command 'nosuch'"), std::string::npos) << result.err;
    EXPECT_NE(result.err.find("get, set"), std::string::npos) << result.err;
}

TEST(CommandErrors_test, MissingCommandListsTheCommandsAndHelpStillWorks) {
    const auto missing = plexus({});
    EXPECT_EQ(missing.exit_code, 2);
    EXPECT_NE(missing.err.find("a command is required; the commands are: "), std::string::npos)
        << missing.err;
    EXPECT_EQ(plexus({"--help"}).exit_code, 0);
}

TEST(CommandErrors_test, ConnectHelpShowsTheCarrierGrammar) {
    cli::CommandLine command_line;
    const std::string help = command_line.app().get_subcommand("connect")->help();
    for (const char* part : {"tcp", "udp", "mcast", "local", "send.NAME", "recv.NAME", "FIRST dot",
                             "portmonitor", "priority", "tc decay time", "ex./face/out:-1", "qos.prio.N",
                             "tcp+recv.portmonitor+type.lua+file.certainty+threshold.0.8"})
        EXPECT_NE(help.find(part), std::string::npos) << "'" << part << "' missing from:\n" << help;
}

}  // namespace
}  // namespace plexus::test
