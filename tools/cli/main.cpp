// plexus: the command-line tool. Parses the command line and hands over to one command.
#include "command_line.hpp"

int main(int argc, char** argv) {
    plexus::cli::CommandLine command_line;
    return command_line.run(argc, argv);
}
