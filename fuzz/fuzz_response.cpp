// Camera response JSON ("lightprobe.response/1") through load_response.
#include "core/error.h"
#include "fuzz/fuzz_input.h"
#include "hdr/response.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = lp::fuzz::write_input("response.json", data, size);
  try {
    lp::load_response(path);
  } catch (const lp::InputError&) {
  }
  return 0;
}
