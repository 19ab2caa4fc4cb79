// Exposure bracketing with a GenICam camera's own sequencer (SFNC "Sequencer Control"):
// the camera switches exposure between frames itself, so every frame of a bracket is
// taken at full frame rate and at the exposure it was programmed for, where per-frame
// feature writes lose a frame or more to each write's round trip.
//
// The program is plain SFNC feature writes, run through a small feature interface so the
// same code drives Aravis (probe/aravis_source.cpp) and the simulated camera of the tests.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace lp {

// What a GenICam node map offers, as much as the sequencer needs. Each call returns
// false (and sets *error when given) when the feature is missing or the write fails.
class GenicamFeatures {
 public:
  virtual ~GenicamFeatures() = default;
  virtual bool available(const std::string& feature) = 0;
  virtual bool set_enum(const std::string& feature, const std::string& value, std::string* error) = 0;
  virtual bool set_integer(const std::string& feature, int64_t value, std::string* error) = 0;
  virtual bool set_float(const std::string& feature, double value, std::string* error) = 0;
  virtual bool execute(const std::string& command, std::string* error) = 0;
  // Largest value an integer feature accepts (nullopt when missing).
  virtual std::optional<int64_t> integer_max(const std::string& feature) = 0;
};

struct SequencerSetup {
  bool ok = false;
  std::string reason;                 // why not, when !ok (one line)
  std::string exposure_feature;       // the feature that was programmed
  std::vector<double> exposure_us;    // set i -> exposure, microseconds
};

// Programs sets 0..n-1 with the given exposures (seconds), each set advancing to the
// next on every frame (the last back to 0), starting at set 0, and turns the sequencer
// on. When the camera has no SFNC sequencer, too few sets, or refuses a write, the
// sequencer is left off and the reason given: the caller falls back to feature writes.
SequencerSetup start_exposure_sequencer(GenicamFeatures& camera, const std::vector<double>& exposure_s);

// Turns the sequencer off (best effort; a lost camera is not an error here).
void stop_exposure_sequencer(GenicamFeatures& camera);

}  // namespace lp
