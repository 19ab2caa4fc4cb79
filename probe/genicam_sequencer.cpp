#include "probe/genicam_sequencer.h"

#include <cmath>

namespace lp {

namespace {

// SFNC names the trigger that advances a set differently across vendors' versions; any
// per-frame one does.
const char* const kPerFrameTriggers[] = {"FrameStart", "ExposureStart", "ExposureActive", "FrameEnd"};

}  // namespace

SequencerSetup start_exposure_sequencer(GenicamFeatures& camera, const std::vector<double>& exposure_s) {
  SequencerSetup setup;
  const int n = int(exposure_s.size());
  if (n < 2) {
    setup.reason = "a sequencer needs at least 2 exposures";
    return setup;
  }
  for (const char* f : {"SequencerMode", "SequencerSetSelector", "SequencerSetSave", "SequencerSetNext"}) {
    if (!camera.available(f)) {
      setup.reason = std::string("no sequencer (the camera has no ") + f + ")";
      return setup;
    }
  }
  setup.exposure_feature = camera.available("ExposureTime") ? "ExposureTime" : "ExposureTimeAbs";
  if (!camera.available(setup.exposure_feature)) {
    setup.reason = "no exposure feature (ExposureTime / ExposureTimeAbs)";
    return setup;
  }
  const std::optional<int64_t> last_set = camera.integer_max("SequencerSetSelector");
  if (!last_set || *last_set < n - 1) {
    setup.reason = "the sequencer has " + std::to_string(last_set ? *last_set + 1 : 0) + " sets, the bracket needs " +
                   std::to_string(n);
    return setup;
  }
  std::string error;
  auto failed = [&](const std::string& what) {
    setup.reason = "sequencer: " + what + (error.empty() ? "" : ": " + error);
    stop_exposure_sequencer(camera);
    return setup;
  };
  // Sets can only be written with the sequencer off and in configuration mode.
  if (!camera.set_enum("SequencerMode", "Off", &error)) return failed("SequencerMode=Off");
  if (camera.available("SequencerConfigurationMode") &&
      !camera.set_enum("SequencerConfigurationMode", "On", &error))
    return failed("SequencerConfigurationMode=On");
  // Cameras with a feature list (SFNC 2.x) must be told that sets carry the exposure.
  if (camera.available("SequencerFeatureSelector") && camera.available("SequencerFeatureEnable")) {
    if (!camera.set_enum("SequencerFeatureSelector", setup.exposure_feature, &error) ||
        !camera.set_integer("SequencerFeatureEnable", 1, &error))
      return failed("enabling " + setup.exposure_feature + " in the sets");
  }
  for (int i = 0; i < n; ++i) {
    const double us = exposure_s[size_t(i)] * 1e6;
    if (!camera.set_integer("SequencerSetSelector", i, &error)) return failed("SequencerSetSelector=" + std::to_string(i));
    if (!camera.set_float(setup.exposure_feature, us, &error))
      return failed(setup.exposure_feature + "=" + std::to_string(us) + " in set " + std::to_string(i));
    if (camera.available("SequencerPathSelector") && !camera.set_integer("SequencerPathSelector", 0, &error))
      return failed("SequencerPathSelector=0");
    if (!camera.set_integer("SequencerSetNext", (i + 1) % n, &error)) return failed("SequencerSetNext");
    if (camera.available("SequencerTriggerSource")) {
      bool set = false;
      for (const char* trigger : kPerFrameTriggers)
        if (camera.set_enum("SequencerTriggerSource", trigger, nullptr)) {
          set = true;
          break;
        }
      if (!set) return failed("no per-frame SequencerTriggerSource");
    }
    if (!camera.execute("SequencerSetSave", &error)) return failed("SequencerSetSave of set " + std::to_string(i));
    setup.exposure_us.push_back(us);
  }
  if (camera.available("SequencerSetStart") && !camera.set_integer("SequencerSetStart", 0, &error))
    return failed("SequencerSetStart=0");
  if (camera.available("SequencerConfigurationMode") &&
      !camera.set_enum("SequencerConfigurationMode", "Off", &error))
    return failed("SequencerConfigurationMode=Off");
  if (!camera.set_enum("SequencerMode", "On", &error)) return failed("SequencerMode=On");
  setup.ok = true;
  return setup;
}

void stop_exposure_sequencer(GenicamFeatures& camera) {
  if (camera.available("SequencerMode")) camera.set_enum("SequencerMode", "Off", nullptr);
  if (camera.available("SequencerConfigurationMode")) camera.set_enum("SequencerConfigurationMode", "Off", nullptr);
}

}  // namespace lp
