#pragma once
// The `plexus` command line: every command and option, built into a CLI11 App that main() parses.
// Built apart from main() so tests can walk the same App (every subcommand, every option) that
// users get.

#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "apps/app_commands.hpp"
#include "commands.hpp"

namespace plexus::cli {

/// The options of `plexus pki`.
struct PkiOptions {
    std::string ca;
    std::string name;
    std::string out;
    bool names = false;
    bool json = false;
    int days = 3650;
    std::vector<std::string> web;
};

class CommandLine {
public:
    CommandLine();
    CommandLine(const CommandLine&) = delete;
    CommandLine& operator=(const CommandLine&) = delete;

    /// The App with every command; parsing it runs the chosen command.
    const CLI::App& app() const { return app_; }
    /// Parses argv, runs the command and returns DESIGN's exit status (2 for a usage error).
    int run(int argc, char** argv);

private:
    void add_port_commands();
    void add_inspect_commands();
    void add_app_commands();
    void add_what_if_command();
    void add_recording_commands();
    void add_call_commands();
    void add_pki_commands();  // pki_commands.cpp

    CLI::App app_;
    Common common_;
    std::string secret_file_;
    std::string identity_;
    int status_ = 0;

    // Where the options land; commands read them in their callbacks.
    bool json_ = false;
    bool web_token_ = false;  ///< plexus web --token
    std::string source_;
    std::string destination_;
    std::string carrier_;
    bool persist_ = false;
    bool strict_ = false;
    std::string port_;
    std::vector<std::string> destinations_;
    ReadOptions read_options_;
    double wait_timeout_ = 0;
    int ping_count_ = 3;
    EventsOptions events_options_;
    std::vector<std::string> assignments_;
    std::string app_file_;
    UpOptions up_options_;
    std::vector<std::string> node_sockets_;
    WhatIfArgs what_if_args_;
    RecordOptions record_options_;
    PlayOptions play_options_;
    CallOptions call_options_;
    ServeOptions serve_options_;
    PkiOptions pki_options_;
};

}  // namespace plexus::cli
