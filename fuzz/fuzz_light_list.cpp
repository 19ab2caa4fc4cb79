// Light-list JSON (CONVENTIONS.md) through light_list_from_json, and a list that parses
// back out through to_json (what merge and the servers do with an upstream list).
#include "core/error.h"
#include "core/light_list.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  try {
    const lp::LightList list = lp::light_list_from_json(lp::fuzz::as_text(data, size), "fuzz input");
    lp::to_json(list, false);
    lp::total_power(list.lights);
  } catch (const lp::InputError&) {
  }
  return 0;
}
