#pragma once
// Runs a program to completion or to a deadline, keeping what it wrote on stderr: for tests that
// drive the `plexus` CLI without a daemon. The child is killed if it outlives the deadline, also
// when the test fails, so nothing it starts is left behind.

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace plexus::test {

struct ProgramResult {
    std::optional<int> exit_code;  ///< nullopt: still running at the deadline (then killed)
    std::string err;               ///< everything written on stderr
};

/// Runs argv[0] with argv (stdin and stdout /dev/null) until it exits or `deadline` passes.
ProgramResult run_program(const std::vector<std::string>& argv, std::chrono::milliseconds deadline);

}  // namespace plexus::test
