// The command table over CLI11: the only translation unit that includes it.
#include "cli/command_table.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <exception>
#include <map>
#include <sstream>
#include <utility>

#include "core/error.h"
#include "core/interrupt.h"
#include "core/limits.h"
#include "core/warnings.h"

namespace lp::cli {

namespace {

constexpr const char* kDescription =
    "lightprobe: calibrate cameras, capture HDR light probes and turn them into\n"
    "directional lights for renderers, live.\n\n"
    "Example session:\n"
    "  lightprobe synth scene -o scene.exr --size 1024x512\n"
    "  lightprobe info scene.exr\n"
    "  lightprobe sample scene.exr --method q2tree --n 256 -o lights.json --overlay lights.png\n"
    "  lightprobe eval sampling scene.exr --methods all -o eval/\n";

constexpr const char* kSharedOptions =
    "Every command also takes --json (its report as one JSON object on stdout),\n"
    "--no-progress (no progress bars), --config FILE (TOML, one [section] per command),\n"
    "--max-pixels N and --max-lights N (raise the limits of docs/limits.md).";

// The groups of two-word commands, by stage.
const std::map<std::string, std::string>& group_help() {
  static const std::map<std::string, std::string> help = {
      {"synth", "Ground-truth makers"},
      {"calib", "Camera calibration"},
      {"hdr", "Exposure brackets and log sensors -> radiance"},
      {"probe", "Mirror-ball and fisheye probes -> environment maps"},
      {"estimate", "Lighting without a probe, from camera metadata over space"},
      {"eval", "Speed against accuracy of each method"},
  };
  return help;
}

// CLI11 shows a negated flag ("!--no-progress") as "--no-progress{false}" in the help; what a
// user types has no braces.
class HelpFormatter final : public CLI::Formatter {
 public:
  std::string make_option_name(const CLI::Option* opt, bool is_positional) const override {
    std::string name = CLI::Formatter::make_option_name(opt, is_positional);
    for (size_t open; (open = name.find('{')) != std::string::npos;) {
      const size_t close = name.find('}', open);
      if (close == std::string::npos) break;
      name.erase(open, close - open + 1);
    }
    return name;
  }
};

class CliFlags final : public Flags {
 public:
  explicit CliFlags(CLI::App* app) : app_(app) {}
  Flags& arg(const char* name, std::string& target, const char* help) override { return keep(app_->add_option(name, target, help)); }
  Flags& arg(const char* name, std::vector<std::string>& target, const char* help) override {
    return keep(app_->add_option(name, target, help)->default_str(""));  // not "[]"
  }
  Flags& opt(const char* names, std::string& target, const char* help) override { return keep(app_->add_option(names, target, help)); }
  Flags& opt(const char* names, int& target, const char* help) override { return keep(app_->add_option(names, target, help)); }
  Flags& opt(const char* names, double& target, const char* help) override { return keep(app_->add_option(names, target, help)); }
  Flags& opt(const char* names, uint64_t& target, const char* help) override { return keep(app_->add_option(names, target, help)); }
  Flags& flag(const char* names, bool& target, const char* help) override { return keep(app_->add_flag(names, target, help)); }
  Flags& required() override {
    last_->required();
    return *this;
  }
  Flags& one_of(std::vector<std::string> values) override {
    last_->check(CLI::IsMember(std::move(values)));
    return *this;
  }
  Flags& non_empty() override {
    last_->check(CLI::Validator([](std::string& v) { return v.empty() ? std::string("must not be empty") : std::string(); },
                                ""));  // no name: the help keeps "TEXT"
    return *this;
  }
  Flags& given(bool& target) override {
    bool* seen = &target;  // validators run only on values given, never on the default
    last_->check(CLI::Validator([seen](std::string&) { return *seen = true, std::string(); }, ""));
    return *this;
  }

 private:
  Flags& keep(CLI::Option* option) {
    last_ = option;
    return *this;
  }
  CLI::App* app_;
  CLI::Option* last_ = nullptr;
};

std::vector<Command> all_commands() {
  std::vector<Command> all;
  for (auto stage : {map_commands, calib_commands, hdr_commands, probe_commands, sample_commands, sh_commands, render_commands,
                     estimate_commands, live_commands, synth_commands, eval_commands}) {
    for (Command& c : stage()) all.push_back(std::move(c));
  }
  return all;
}

std::string example_footer(const std::string& example) {
  std::ostringstream s;
  s << "Example:\n";
  std::istringstream lines(example);
  for (std::string line; std::getline(lines, line);) s << "  " << line << "\n";
  s << "\n" << kSharedOptions;
  return s.str();
}

// One line for a --config file's error, naming the file: CLI11 says "INI was not able to parse
// sample.metod" on two lines, without the file.
std::string config_error_line(const CLI::App& app, const CLI::ConfigError& e) {
  const CLI::Option* config = app.get_config_ptr();
  const std::string file = config && !config->results().empty() ? config->results().front() : "--config";
  const std::string what = e.what();
  const std::string prefix = "INI was not able to parse ";
  if (what.rfind(prefix, 0) != 0) return file + ": " + what;
  std::string item = what.substr(prefix.size());
  std::replace(item.begin(), item.end(), '.', ' ');  // "probe unwrap type": a command's words, then the key
  const size_t space = item.rfind(' ');
  const std::string section = space == std::string::npos ? "" : item.substr(0, space);
  const std::string key = space == std::string::npos ? item : item.substr(space + 1);
  if (key == "++" || key == "--") return file + ": [" + section + "] is not a command (a section per command, e.g. [stream])";
  if (item.rfind('[', 0) == 0)  // "[sample" without its ']': CLI11 reads the line as a key
    return file + ": '" + item + "' is not a section header (a ']' is missing)";
  if (section.empty()) return file + ": '" + key + "' is not an option every command takes (put it in its command's [section])";
  return file + ": '" + key + "' is not an option of " + section;
}

// One line for a usage error, naming the command it is about: CLI11 prints "MAP is required"
// and "Run with --help for more information." on two lines, without saying whose MAP, and
// answers a misspelt command ("lightprobe smaple") with "A subcommand is required".
std::string usage_error_line(const CLI::App& app, const CLI::ParseError& e) {
  const CLI::App* deepest = &app;
  std::string path;
  for (std::vector<CLI::App*> subs = app.get_subcommands(); !subs.empty(); subs = subs.front()->get_subcommands()) {
    deepest = subs.front();
    path += (path.empty() ? "" : " ") + deepest->get_name();
  }
  const std::string command = path.empty() ? "lightprobe" : "lightprobe " + path;
  std::string what = e.what();
  // A word that no command took: left on the command, or on the top (fallthrough).
  std::vector<std::string> extra = deepest->remaining();
  if (extra.empty()) extra = app.remaining(true);
  if (what == "A subcommand is required" && !extra.empty() && extra.front().rfind('-', 0) != 0) {
    std::string names;
    for (const CLI::App* sub : deepest->get_subcommands({}))
      names += (names.empty() ? "" : ", ") + sub->get_name();
    what = fmt::format("'{}' is not a command of {} (commands: {})", extra.front(), command, names);
  } else if (!path.empty()) {
    what = path + ": " + what;
  }
  const CLI::Option* config = app.get_config_ptr();
  const std::string from_config =
      config && !config->results().empty() ? " (the command line with " + config->results().front() + ")" : "";
  return what + from_config + "; see " + command + " --help";
}

// Parses the command line (and a --config file) against the table; runs the chosen
// handler only when `run`.
int parse_command_line(int argc, char** argv, bool run) {
  CLI::App app{kDescription, "lightprobe"};
  app.set_version_flag("--version", std::string("lightprobe ") + LIGHTPROBE_VERSION);
  app.require_subcommand(1);
  app.formatter(std::make_shared<HelpFormatter>());  // before the subcommands, which copy it
  // A rig's setup in one file: TOML with a section per command, e.g. [stream] source = "aravis"
  // (usable after the subcommand too: lightprobe stream --config rig.toml).
  app.set_config("--config", "", "TOML file of options, one [section] per command (e.g. [stream])");
  // A misspelt key or section is an error: ignored (CLI11's default), `metod = "mediancut"`
  // ran the default method with exit 0. Sections of other commands are theirs, not extras.
  app.allow_config_extras(CLI::config_extras_mode::error);
  app.fallthrough();  // shared options may follow the subcommand
  app.option_defaults()->always_capture_default();
  Output out;
  app.add_flag("--json", out.json, "Print the report as one JSON object on stdout")->configurable(false);
  app.add_flag("!--no-progress", out.progress, "Never draw progress bars");
  // The limits of core/limits.h, for the rare run that needs more (docs/limits.md).
  Limits limits;
  app.add_option("--max-pixels", limits.max_pixels, "Largest image or map read, made or written, in pixels");
  app.add_option("--max-lights", limits.max_lights, "Largest number of lights asked for");

  std::map<std::string, CLI::App*> groups;
  std::vector<std::pair<CLI::App*, Handler>> handlers;
  for (const Command& command : all_commands()) {
    CLI::App* parent = &app;
    std::string name = command.path;
    if (const size_t space = name.find(' '); space != std::string::npos) {
      const std::string group = name.substr(0, space);
      name = name.substr(space + 1);
      CLI::App*& g = groups[group];
      if (!g) {
        g = app.add_subcommand(group, group_help().at(group));
        g->require_subcommand(1);
      }
      parent = g;
    }
    CLI::App* sub = parent->add_subcommand(name, command.help);
    sub->footer(example_footer(command.example));
    CliFlags flags(sub);
    handlers.emplace_back(sub, command.declare(flags));
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::Success& e) {
    return app.exit(e);
  } catch (const CLI::FileError& e) {  // the --config file: one line, as every input error
    std::fprintf(stderr, "lightprobe: %s\n", e.what());
    return 2;
  } catch (const CLI::ConfigError& e) {
    std::fprintf(stderr, "lightprobe: %s\n", config_error_line(app, e).c_str());
    return 2;
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "lightprobe: %s\n", usage_error_line(app, e).c_str());
    return 2;
  }
  if (!run) return 0;

  try {
    set_limits(limits);
    for (const auto& [sub, handler] : handlers) {
      if (!sub->parsed()) continue;
      const int code = handler(out);
      // A command that stopped itself on a deferred signal (stream, merge) ends with its code.
      return interrupt_exit_code() ? interrupt_exit_code() : code;
    }
  } catch (const lp::InputError& e) {
    std::fprintf(stderr, "lightprobe: %s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lightprobe: internal error: %s\n", e.what());
    return 1;
  }
  return 1;
}

}  // namespace

int run_command_line(int argc, char** argv) {
  install_interrupt_handlers();  // SIGINT/SIGTERM: temp files removed, exit 130/143
  set_warning_sink([](const std::string& line) { std::fprintf(stderr, "lightprobe: warning: %s\n", line.c_str()); });
  const int code = parse_command_line(argc, argv, true);
  end_if_interrupted();  // a signal that landed as the command finished still ends it with 128 + signal
  return code;
}

int check_command_line(int argc, char** argv) { return parse_command_line(argc, argv, false); }

}  // namespace lp::cli
