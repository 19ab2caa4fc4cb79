// Camera response JSON ("lightprobe.response/1") through load_response.
#include "fuzz/fuzz_input.h"
#include "hdr/response.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return lp::fuzz::read_as_file("response.json", data, size, [](const std::string& path) { lp::load_response(path); });
}
