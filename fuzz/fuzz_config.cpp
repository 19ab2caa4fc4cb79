// The --config file (TOML, one [section] per command) of `lightprobe stream`, parsed by
// the real command table against every command's declared options, handlers not run.
#include "cli/command_table.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string path = lp::fuzz::write_input("rig.toml", data, size);
  std::string argv0 = "lightprobe", command = "stream", option = "--config";
  char* argv[] = {argv0.data(), command.data(), option.data(), path.data(), nullptr};
  lp::cli::check_command_line(4, argv);
  return 0;
}
