// Every numeric option of every `plexus` command, found by walking the CLI's own command line, is
// fed NaN, infinities, negatives, zero, huge numbers and non-numbers. Each must be refused as a
// usage error (exit 2) whose one-line message names the option, or have a meaning the option's
// help states (listed below with its reason) — never a loop, a hang or a wrap-around.
//
// The real binary runs each case with a deadline and no daemon: --socket names a path that does
// not exist and --names a loopback port nobody listens on, so a value that gets past parsing
// fails fast (exit 4) or hangs, and either is reported as "accepted the bad value".
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <sstream>
#include <string>
#include <vector>

#include "../../common/slowdown.hpp"
#include "command_line.hpp"
#include "run_program.hpp"

namespace plexus::test {
namespace {

using namespace std::chrono_literals;

struct NumericOption {
    std::vector<std::string> command;      ///< e.g. {"param", "set"}
    std::vector<std::string> positionals;  ///< placeholders for the command's required positionals
    std::string name;                      ///< e.g. "--timeout"
    std::string type;                      ///< CLI11's type name: INT, UINT, FLOAT...
    std::string description;               ///< its help text
};

/// A value with a meaning the option's help states, so it is not a usage error.
struct DocumentedMeaning {
    std::string command;  ///< the command path, words joined by spaces
    std::string option;
    std::string value;
    std::string help_says;  ///< what the option's help must say, so the meaning is documented
    std::string reason;
};

const std::vector<DocumentedMeaning> documented_meanings = {
    {"wait", "--timeout", "0", "0 waits forever",
     "waiting for a port with no deadline is the point of `wait` in scripts that start things in any order"},
    {"record", "--max-bytes", "99999999999", "any number of bytes",
     "a recording of a hundred gigabytes is an ordinary day of camera images"},
    {"record", "--split-bytes", "99999999999", "any number of bytes", "as --max-bytes"},
    {"play", "--start", "0", "0: from the start", "the default: play the whole recording"},
    {"play", "--wait", "0", "0: do not wait", "connections made after the player started are fine too"},
};

bool is_numeric(const std::string& type) {
    for (const char* prefix : {"INT", "UINT", "FLOAT", "NUMBER"})
        if (type.rfind(prefix, 0) == 0)
            return true;
    return false;
}

void collect(const CLI::App& app, std::vector<std::string> path, std::vector<NumericOption>& found) {
    if (app.get_parent() != nullptr)
        path.push_back(app.get_name());
    std::vector<std::string> positionals;
    for (const CLI::Option* option : app.get_options()) {
        // A placeholder that is both a valid port name and a file that does not exist.
        if (option->get_positional() && option->get_required())
            positionals.push_back(option->get_name() == "KEY=VALUE" ? "key=1" : "/plexus-option-test/none");
    }
    for (const CLI::Option* option : app.get_options()) {
        if (is_numeric(option->get_type_name()))
            found.push_back(
                {path, positionals, option->get_name(), option->get_type_name(), option->get_description()});
    }
    for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; }))
        collect(*sub, path, found);
}

std::vector<NumericOption> numeric_options() {
    static const std::vector<NumericOption> options = [] {
        cli::CommandLine command_line;
        std::vector<NumericOption> found;
        collect(command_line.app(), {}, found);
        return found;
    }();
    return options;
}

std::string joined(const std::vector<std::string>& words) {
    std::string text;
    for (const auto& word : words)
        text += (text.empty() ? "" : " ") + word;
    return text;
}

/// The bad values for an option of CLI11 type `type`: every kind the issue names.
std::vector<std::string> bad_values(const std::string& type) {
    std::vector<std::string> values = {
        "nan",
        "-nan",
        "NaN",  // not a number
        "inf",
        "-inf",
        "infinity",  // infinities
        "-1",
        "-5",                    // negative (wraps in an unsigned)
        "0",                     // zero
        "99999999999",           // over 32 bits
        "99999999999999999999",  // over 64 bits
        "1e300",                 // huge
        "abc",
        "",
        "1.5x",
        "--",  // not numbers
    };
    if (type.rfind("FLOAT", 0) != 0)
        values.push_back("2.5");  // a fraction where a whole number is wanted
    return values;
}

const DocumentedMeaning* documented(const NumericOption& option, const std::string& value) {
    for (const auto& meaning : documented_meanings)
        if (meaning.command == joined(option.command) && meaning.option == option.name &&
            meaning.value == value)
            return &meaning;
    return nullptr;
}

std::string first_line(const std::string& text) {
    return text.substr(0, text.find('\n'));
}

/// Runs `plexus ... COMMAND POSITIONALS OPTION=VALUE` where nothing past parsing can succeed.
ProgramResult run_with(const NumericOption& option, const std::string& value) {
    std::vector<std::string> argv = {PLEXUS_CLI_PATH, "--socket", "/nonexistent/plexus-option-test.sock",
                                     "--names", "127.0.0.1:1"};
    argv.insert(argv.end(), option.command.begin(), option.command.end());
    argv.insert(argv.end(), option.positionals.begin(), option.positionals.end());
    argv.push_back(option.name + "=" + value);  // `=`: "-5" is the value, not an option
    return run_program(argv, slower(3s));
}

/// Empty when the outcome is a clear usage error, else what went wrong.
std::string judge_refusal(const NumericOption& option, const std::string& value,
                          const ProgramResult& result) {
    const std::string shown = "'" + value + "'";
    const std::string line = first_line(result.err);
    if (!result.exit_code)
        return shown + " accepted: still running after the deadline (killed)";
    if (*result.exit_code != 2)
        return shown + " accepted: exit " + std::to_string(*result.exit_code) + " (" + line + ")";
    if (line.find(option.name) == std::string::npos)
        return shown + " exit 2, but the message does not name " + option.name + ": " + line;
    // A message that prints DBL_MAX's 309 digits, or a whole page, is not a clear one.
    if (line.size() > 160)
        return shown + " exit 2, but the message is " + std::to_string(line.size()) +
               " characters long: " + line.substr(0, 160) + "...";
    return {};
}

/// Names the case in gtest's messages, instead of the bytes of the struct.
void PrintTo(const NumericOption& option, std::ostream* out) {
    *out << "plexus " << joined(option.command) << " " << option.name;
}

class NumericOption_test : public testing::TestWithParam<NumericOption> {};

TEST_P(NumericOption_test, RefusesBadValuesOrDocumentsThem) {
    const NumericOption& option = GetParam();
    std::vector<std::string> problems;
    for (const auto& value : bad_values(option.type)) {
        if (const auto* meaning = documented(option, value)) {
            EXPECT_NE(option.description.find(meaning->help_says), std::string::npos)
                << option.name << " " << value << " is listed as meaning what its help says, \""
                << meaning->help_says << "\", but the help says: " << option.description;
            continue;
        }
        const std::string problem = judge_refusal(option, value, run_with(option, value));
        if (!problem.empty())
            problems.push_back(problem);
    }
    std::ostringstream report;
    for (const auto& problem : problems)
        report << "\n  " << problem;
    EXPECT_TRUE(problems.empty()) << "plexus " << joined(option.command) << " " << option.name << " ("
                                  << option.type << "):" << report.str();
}

TEST_P(NumericOption_test, AcceptsAnOrdinaryValue) {
    // A validator that refuses everything would pass the test above: 1 is in every option's range.
    const NumericOption& option = GetParam();
    const auto result = run_with(option, "1");
    const bool refused =
        result.exit_code == 2 && first_line(result.err).find(option.name) != std::string::npos;
    EXPECT_FALSE(refused) << option.name << "=1 refused: " << first_line(result.err);
}

std::string test_name(const testing::TestParamInfo<NumericOption>& info) {
    std::string name = joined(info.param.command) + "_" + info.param.name;
    std::replace_if(
        name.begin(), name.end(), [](char c) { return !std::isalnum(static_cast<unsigned char>(c)); }, '_');
    name.erase(0, name.find_first_not_of('_'));
    std::string squeezed;
    for (char c : name)
        if (!(c == '_' && !squeezed.empty() && squeezed.back() == '_'))
            squeezed += c;
    return squeezed;
}

INSTANTIATE_TEST_SUITE_P(EveryCommand, NumericOption_test, testing::ValuesIn(numeric_options()), test_name);

TEST(NumericOptions_test, FindsTheKnownNumericOptions) {
    // The walk must see the App's options: if it found none, every test above would vanish.
    std::vector<std::string> found;
    for (const auto& option : numeric_options())
        found.push_back(joined(option.command) + " " + option.name);
    for (const char* known : {"read --count", "read --timeout", "read --queue", "wait --timeout",
                              "ping --count", "events --interval", "events --count", "up --timeout"})
        EXPECT_NE(std::find(found.begin(), found.end(), known), found.end()) << known << " not found";
}

}  // namespace
}  // namespace plexus::test
