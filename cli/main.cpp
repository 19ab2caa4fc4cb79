// lightprobe: cameras into live light probes. The commands are a table
// (cli/command_table.h), each declared beside its handler in cli/cmd_<stage>.cpp; see
// ../shared/CONVENTIONS.md "The command line" for the shapes scripts rely on.
#include "cli/command_table.h"

int main(int argc, char** argv) { return lp::cli::run_command_line(argc, argv); }
