// The table of `lightprobe` subcommands. Each command is declared once, beside its
// handler in cli/cmd_<stage>.cpp: its path ("eval sampling"), a one-line help, a worked
// example that --help shows, its options (defaults shown by --help) and the handler.
// Options shared by every command (--json, --no-progress, --config) are declared once,
// here. Only command_table.cpp knows CLI11 (slow to compile).
//
// A handler parses its arguments into library options, validates, loads, makes one
// library call, writes and reports. Exit codes (CONVENTIONS.md): 0 success, 2 bad input
// or usage (lp::InputError, or a parse error), 1 internal failure.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace lp::cli {

// Where reports go: with --json one JSON object on stdout; human text on stdout
// otherwise (stderr when --json).
struct Output {
  bool json = false;
  bool progress = true;  // progress bars (shown only on a terminal anyway)
};

// What a command's declaration sees of the parser. Every call returns *this so that
// `required()` and `one_of()` apply to the option declared last.
class Flags {
 public:
  virtual ~Flags() = default;
  // Positional arguments, in the order declared.
  virtual Flags& arg(const char* name, std::string& target, const char* help) = 0;
  virtual Flags& arg(const char* name, std::vector<std::string>& target, const char* help) = 0;
  // Options named "--name" or "-o,--output"; the target's value is the default shown.
  virtual Flags& opt(const char* names, std::string& target, const char* help) = 0;
  virtual Flags& opt(const char* names, int& target, const char* help) = 0;
  virtual Flags& opt(const char* names, double& target, const char* help) = 0;
  virtual Flags& opt(const char* names, uint64_t& target, const char* help) = 0;
  // A flag sets its target to true; a name starting with "!" ("!--no-sweep") sets it false.
  virtual Flags& flag(const char* names, bool& target, const char* help) = 0;
  // The option or argument declared last must be given.
  virtual Flags& required() = 0;
  // The option declared last takes one of these values.
  virtual Flags& one_of(std::vector<std::string> values) = 0;
  // The option declared last, when given, must not be empty: an empty value would read as
  // "not given" (`--token ""` would otherwise serve without authentication).
  virtual Flags& non_empty() = 0;
  // Sets `target` true when the option declared last is given (command line or --config),
  // for an option whose explicit default means something else than its absence.
  virtual Flags& given(bool& target) = 0;
  // The shared required output: -o,--output.
  Flags& output(std::string& target, const char* help) { return opt("-o,--output", target, help).required(); }
};

using Handler = std::function<int(const Output&)>;

struct Command {
  std::string path;     // "info", "eval sampling": a group's name, then the command's
  std::string help;     // one line, shown in the list of commands
  std::string example;  // a worked example (one or more lines), shown by --help
  // Declares the command's options, bound to an argument struct it owns, and returns
  // the handler that runs on them.
  std::function<Handler(Flags&)> declare;
};

// Each stage's commands (cli/cmd_<stage>.cpp), listed by --help in this order.
std::vector<Command> map_commands();       // info, convert, preview
std::vector<Command> calib_commands();     // calib geometric|compare|photometric|colour
std::vector<Command> hdr_commands();       // hdr response|fuse
std::vector<Command> probe_commands();     // probe unwrap|register
std::vector<Command> sample_commands();    // sample
std::vector<Command> sh_commands();        // sh
std::vector<Command> render_commands();    // tables
std::vector<Command> estimate_commands();  // estimate metadata|query
std::vector<Command> live_commands();      // stream, merge
std::vector<Command> synth_commands();     // synth scene|sequence|boards|bracket|probe|walkthrough
std::vector<Command> eval_commands();      // eval sampling|temporal|...

// Parses the command line against the table, runs the chosen handler and maps its
// exceptions to exit codes.
int run_command_line(int argc, char** argv);
// Only parses (the --config file included): 0 when the line parses, 2 on a parse error,
// never running a handler. For the config-file fuzzer.
int check_command_line(int argc, char** argv);

}  // namespace lp::cli
