// timestamps.txt beside a sequence of three maps: through find_map_sequence (sample,
// eval temporal) and through the replay source's sidecar reader (stream --source replay:).
// The map files stay empty: neither reads them until a frame is asked for.
#include "core/error.h"
#include "core/map_sequence.h"
#include "fuzz/fuzz_input.h"
#include "probe/camera_source.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = [] {
    for (const char* name : {"a.pfm", "b.pfm", "c.pfm"}) lp::fuzz::write_input(name, nullptr, 0);
    return lp::fuzz::scratch_dir();
  }();
  lp::fuzz::write_input("timestamps.txt", data, size);
  try {
    lp::find_map_sequence({dir});
  } catch (const lp::InputError&) {
  }
  try {
    lp::open_source("replay:" + dir);
  } catch (const lp::InputError&) {
  }
  return 0;
}
