// The sequencer program against a simulated SFNC camera that enforces what real ones do
// (sets written only in configuration mode, exposure locked while the sequencer runs,
// a set only takes effect once saved) and then "takes" frames: the exposures the frames
// come out at are the test, not the list of writes.
#include <gtest/gtest.h>

#include <map>
#include <set>

#include "probe/genicam_sequencer.h"

namespace lp {
namespace {

class SimulatedSfncCamera : public GenicamFeatures {
 public:
  explicit SimulatedSfncCamera(int sets = 16, std::string exposure_name = "ExposureTime",
                               std::set<std::string> triggers = {"FrameStart"}, bool has_sequencer = true)
      : sets_(size_t(sets)), exposure_name_(std::move(exposure_name)), triggers_(std::move(triggers)) {
    features_ = {exposure_name_, "Width", "Height"};
    if (has_sequencer)
      for (const char* f : {"SequencerMode", "SequencerConfigurationMode", "SequencerSetSelector", "SequencerSetSave",
                            "SequencerSetNext", "SequencerSetStart", "SequencerPathSelector", "SequencerTriggerSource"})
        features_.insert(f);
  }

  bool available(const std::string& f) override { return features_.count(f) > 0; }

  bool set_enum(const std::string& f, const std::string& v, std::string* error) override {
    ++writes;
    if (f == "SequencerMode") {
      if (v == "On" && configuring_) return refuse(error, "SequencerMode=On while configuring");
      running_ = v == "On";
      if (running_) active_ = start_;
      return true;
    }
    if (f == "SequencerConfigurationMode") {
      if (v == "On" && running_) return refuse(error, "configuration while running");
      configuring_ = v == "On";
      return true;
    }
    if (f == "SequencerTriggerSource") {
      if (!configuring_) return refuse(error, "not configuring");
      if (!triggers_.count(v)) return refuse(error, "trigger " + v + " not supported");
      return true;
    }
    return refuse(error, "no enum " + f);
  }

  bool set_integer(const std::string& f, int64_t v, std::string* error) override {
    ++writes;
    if (!available(f)) return refuse(error, "no feature " + f);
    if (f == "SequencerPathSelector") return true;
    if (!configuring_) return refuse(error, f + " written outside configuration mode");
    if (v < 0 || v >= int64_t(sets_.size())) return refuse(error, f + " out of range");
    if (f == "SequencerSetSelector") selected_ = int(v);
    if (f == "SequencerSetNext") pending_next_ = int(v);
    if (f == "SequencerSetStart") start_ = int(v);
    return true;
  }

  bool set_float(const std::string& f, double v, std::string* error) override {
    ++writes;
    if (f != exposure_name_) return refuse(error, "no float " + f);
    if (running_) return refuse(error, "exposure locked while the sequencer runs");
    exposure_us_ = v;
    return true;
  }

  bool execute(const std::string& c, std::string* error) override {
    ++writes;
    if (c != "SequencerSetSave" || !configuring_) return refuse(error, "cannot execute " + c);
    sets_[size_t(selected_)] = {true, exposure_us_, pending_next_};
    return true;
  }

  std::optional<int64_t> integer_max(const std::string& f) override {
    if (f == "SequencerSetSelector" && available(f)) return int64_t(sets_.size()) - 1;
    return std::nullopt;
  }

  // One frame: the exposure it was taken at.
  double take_frame() {
    if (!running_) return exposure_us_;
    const Set& s = sets_[size_t(active_)];
    EXPECT_TRUE(s.saved) << "the sequencer ran into set " << active_ << ", never saved";
    active_ = s.next;
    return s.exposure_us;
  }

  bool running() const { return running_; }
  int writes = 0;

 private:
  struct Set {
    bool saved = false;
    double exposure_us = 0;
    int next = 0;
  };
  bool refuse(std::string* error, const std::string& why) {
    if (error) *error = why;
    return false;
  }
  std::vector<Set> sets_;
  std::string exposure_name_;
  std::set<std::string> triggers_;
  std::set<std::string> features_;
  bool running_ = false, configuring_ = false;
  int selected_ = 0, pending_next_ = 0, start_ = 0, active_ = 0;
  double exposure_us_ = 10000;
};

TEST(GenicamSequencer, FramesCycleThroughTheBracketAtTheProgrammedExposures) {
  SimulatedSfncCamera camera;
  const SequencerSetup setup = start_exposure_sequencer(camera, {0.0002, 0.002, 0.02});
  ASSERT_TRUE(setup.ok) << setup.reason;
  EXPECT_TRUE(camera.running());
  EXPECT_EQ(setup.exposure_feature, "ExposureTime");
  const double expected[] = {200, 2000, 20000};
  for (int frame = 0; frame < 10; ++frame) EXPECT_DOUBLE_EQ(camera.take_frame(), expected[frame % 3]) << frame;
  stop_exposure_sequencer(camera);
  EXPECT_FALSE(camera.running());
}

TEST(GenicamSequencer, OlderFeatureNamesAndOtherTriggerNamesAreUsed) {
  SimulatedSfncCamera camera(4, "ExposureTimeAbs", {"ExposureActive"});
  const SequencerSetup setup = start_exposure_sequencer(camera, {0.001, 0.004});
  ASSERT_TRUE(setup.ok) << setup.reason;
  EXPECT_EQ(setup.exposure_feature, "ExposureTimeAbs");
  EXPECT_DOUBLE_EQ(camera.take_frame(), 1000);
  EXPECT_DOUBLE_EQ(camera.take_frame(), 4000);
  EXPECT_DOUBLE_EQ(camera.take_frame(), 1000);
}

TEST(GenicamSequencer, TooFewSetsLeavesTheSequencerOffAndSaysWhy) {
  SimulatedSfncCamera camera(2);
  const SequencerSetup setup = start_exposure_sequencer(camera, {0.001, 0.002, 0.004});
  EXPECT_FALSE(setup.ok);
  EXPECT_NE(setup.reason.find("2 sets"), std::string::npos) << setup.reason;
  EXPECT_FALSE(camera.running());
}

TEST(GenicamSequencer, ACameraWithoutOneIsNotTouched) {
  SimulatedSfncCamera camera(16, "ExposureTime", {"FrameStart"}, /*has_sequencer=*/false);
  const SequencerSetup setup = start_exposure_sequencer(camera, {0.001, 0.002});
  EXPECT_FALSE(setup.ok);
  EXPECT_NE(setup.reason.find("no sequencer"), std::string::npos) << setup.reason;
  EXPECT_EQ(camera.writes, 0);
}

TEST(GenicamSequencer, NoPerFrameTriggerFailsCleanly) {
  SimulatedSfncCamera camera(16, "ExposureTime", {"Line1"});
  const SequencerSetup setup = start_exposure_sequencer(camera, {0.001, 0.002});
  EXPECT_FALSE(setup.ok);
  EXPECT_NE(setup.reason.find("SequencerTriggerSource"), std::string::npos) << setup.reason;
  EXPECT_FALSE(camera.running());
  EXPECT_DOUBLE_EQ(camera.take_frame(), 1000);  // the last exposure written stays in force
}

TEST(GenicamSequencer, OneExposureIsNotABracket) {
  SimulatedSfncCamera camera;
  EXPECT_FALSE(start_exposure_sequencer(camera, {0.001}).ok);
}

}  // namespace
}  // namespace lp
