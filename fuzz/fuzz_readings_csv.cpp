// Photometric readings CSV (calib photometric) through read_readings_csv, then the fit
// on what parsed (the command's next step: its checks reject bad readings).
#include "calib/photometric.h"
#include "core/error.h"
#include "fuzz/fuzz_input.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = lp::fuzz::write_input("readings.csv", data, size);
  try {
    std::vector<lp::PhotometricReading> readings = lp::read_readings_csv(path);
    // Region readings name images (not fuzzed here): only number readings go on to the fit.
    bool has_regions = false;
    for (const auto& r : readings) has_regions |= r.region.has_value();
    if (!has_regions && readings.size() <= 64) lp::fit_photometric(readings);
  } catch (const lp::InputError&) {
  }
  return 0;
}
