// stream --exposures auto (live/pipeline.h, hdr/auto_bracket.h): the live chain re-plans
// its bracket from each fused map, the source takes the new exposure list, the plan holds
// on a steady scene, /status and /metrics say what was chosen and why; a source that
// cannot set its exposure is refused at start.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <sstream>
#include <thread>

#include "core/error.h"
#include "live/pipeline.h"
#include "live/stream_session.h"

namespace lp {
namespace {

// A linear 8-bit camera looking at a room (radiance 0.5 .. 2) with a lamp at the image
// centre (the zenith of the fisheye) that can be switched to 2000: code = L t, clipped.
class PaintingCamera : public CameraSource {
 public:
  PaintingCamera(std::atomic<bool>* lamp, std::vector<std::vector<double>>* cycles, std::mutex* mutex)
      : lamp_(lamp), cycles_(cycles), mutex_(mutex) {}
  std::string describe() const override { return "painting camera"; }
  std::optional<ExposureRange> exposure_range() const override { return ExposureRange{1e-5, 1.0}; }
  void set_exposure_cycle(const std::vector<double>& s) override {
    cycle_ = s;
    index_ = 0;
    std::lock_guard<std::mutex> lock(*mutex_);
    cycles_->push_back(s);
  }
  std::optional<CameraFrame> next(double) override {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    CameraFrame f;
    f.exposure_s = cycle_[index_];
    f.bracket_index = int(index_);
    f.sequence = seq_++;
    index_ = (index_ + 1) % cycle_.size();
    const int n = 64;
    f.image.width = f.image.height = n;
    f.image.rgb.resize(size_t(3) * n * n);
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const bool lamp = *lamp_ && std::abs(x - n / 2) < 4 && std::abs(y - n / 2) < 4;
        const double radiance = lamp ? 2000.0 : 0.5 * std::pow(4.0, double(x + y) / (2 * (n - 1)));
        const float code = float(std::round(std::min(1.0, radiance * f.exposure_s) * 255) / 255);
        for (int c = 0; c < 3; ++c) f.image.rgb[3 * (size_t(y) * n + x) + c] = code;
      }
    return f;
  }

 private:
  std::atomic<bool>* lamp_;
  std::vector<std::vector<double>>* cycles_;
  std::mutex* mutex_;
  std::vector<double> cycle_{1e-3};
  size_t index_ = 0;
  int64_t seq_ = 0;
};

LivePipelineOptions auto_options() {
  LivePipelineOptions o;  // a small hemisphere map (the default layout), 8 pharr lights
  o.auto_exposures = true;
  o.width = 90, o.height = 23;
  o.sampling.method = Method::Pharr, o.sampling.count = 8, o.sampling.sampler.upper_only = true;
  return o;
}

// Polls (up to 30 s) until the pipeline has processed `brackets` more brackets.
LiveStats wait_for_brackets(const LivePipeline& p, uint64_t brackets) {
  const uint64_t target = p.stats().brackets_processed + brackets;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (p.stats().brackets_processed < target && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  return p.stats();
}

TEST(AutoBracketLive, ReplansForALampHoldsOnASteadySceneAndSaysWhy) {
  std::atomic<bool> lamp{false};
  std::vector<std::vector<double>> cycles;
  std::mutex mutex;
  LivePipeline p([&] { return std::make_unique<PaintingCamera>(&lamp, &cycles, &mutex); }, auto_options(),
                 [](const LightList&, std::shared_ptr<const EnvMap>) {});
  p.start();
  // The first bracket is the decade-apart default; the room (metered about 1 .. 4 through
  // linear_response's units) is black in it, so the planner looks further, then settles.
  LiveStats s = wait_for_brackets(p, 15);
  ASSERT_GE(s.brackets_processed, 15u) << s.last_error;
  const uint64_t settled = s.bracket_changes;
  s = wait_for_brackets(p, 20);
  EXPECT_EQ(s.bracket_changes, settled) << s.bracket_decision;  // steady scene: no change
  EXPECT_EQ(s.bracket_plan.covered_fraction, 1.0) << s.bracket_plan.reason;
  EXPECT_LE(s.exposures.size(), 3u) << s.bracket_plan.reason;  // 2 stops of room
  {
    std::lock_guard<std::mutex> lock(mutex);
    EXPECT_EQ(cycles.front(), kAutoFirstBracket);
    EXPECT_EQ(cycles.back(), s.exposures);  // the source cycles what /status says
  }
  const size_t dim = s.exposures.size();
  std::printf("room: %s (%s)\n", s.bracket_plan.reason.c_str(), s.bracket_decision.c_str());

  lamp = true;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  // Brackets already captured before the switch still show the dark room (a plan that is
  // covered and unclipped), so wait for the planner to react first, then for it to settle.
  do {
    s = wait_for_brackets(p, 1);
  } while ((s.bracket_changes == settled || s.bracket_plan.covered_fraction < 1.0 ||
            s.bracket_plan.bright_clipped_in_meter) &&
           std::chrono::steady_clock::now() < deadline);
  EXPECT_EQ(s.bracket_plan.covered_fraction, 1.0) << s.bracket_plan.reason;
  EXPECT_FALSE(s.bracket_plan.bright_clipped_in_meter);
  std::printf("lamp: %s (%s)\n", s.bracket_plan.reason.c_str(), s.bracket_decision.c_str());
  // The plan's shortest exposure keeps the lamp under 0.95 of full scale. (The plan: the
  // capture thread may not have handed it to the source yet.)
  EXPECT_LT(s.bracket_plan.exposure_seconds.front() * 2000, 0.95);
  EXPECT_GT(s.bracket_plan.exposure_seconds.size(), dim);
  EXPECT_GT(s.bracket_changes, settled);
  const uint64_t lit = wait_for_brackets(p, 20).bracket_changes;
  s = wait_for_brackets(p, 20);
  EXPECT_EQ(s.bracket_changes, lit);  // and holds again
  EXPECT_EQ(s.exposures, s.bracket_plan.exposure_seconds);  // handed over by now

  // What /status and /metrics show.
  const nlohmann::json j = bracket_json(s);
  EXPECT_EQ(j["mode"], "auto");
  EXPECT_EQ(j["exposure_seconds"].size(), s.exposures.size());
  EXPECT_NE(j["reason"].get<std::string>().find("exposures"), std::string::npos);
  EXPECT_EQ(j["limit"], "none");
  const std::string metrics = p.metrics();
  EXPECT_NE(metrics.find("lightprobe_bracket_exposures " + std::to_string(s.exposures.size())), std::string::npos);
  EXPECT_NE(metrics.find("lightprobe_bracket_exposure_seconds{index=\"0\"}"), std::string::npos);
  EXPECT_NE(metrics.find("lightprobe_bracket_changes_total"), std::string::npos);
  // promtool refuses gauges named like a counter's or a histogram's parts.
  std::istringstream lines(metrics);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind("# TYPE ", 0) != 0 || line.find(" gauge") == std::string::npos) continue;
    const std::string name = line.substr(7, line.find(' ', 7) - 7);
    for (const char* suffix : {"_count", "_total", "_sum", "_bucket"})
      EXPECT_FALSE(name.size() > std::strlen(suffix) && name.ends_with(suffix)) << name;
  }
  p.stop();
}

TEST(AutoBracketLive, ASourceThatCannotSetExposureIsRefusedAtStart) {
  class Replay : public CameraSource {
   public:
    std::string describe() const override { return "replay:frames"; }
    std::optional<CameraFrame> next(double) override { return std::nullopt; }
    void set_exposure_cycle(const std::vector<double>&) override {}
  };
  LivePipeline p([] { return std::make_unique<Replay>(); }, auto_options(),
                 [](const LightList&, std::shared_ptr<const EnvMap>) {});
  try {
    p.start();
    FAIL() << "started";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()).rfind("replay:frames: cannot set its exposure, so it cannot auto-bracket", 0), 0u)
        << e.what();
  }
}

TEST(AutoBracketLive, TheFirstBracketMovesIntoTheCamerasRange) {
  EXPECT_EQ(auto_first_bracket({1e-5, 1}), kAutoFirstBracket);
  const std::vector<double> slow = auto_first_bracket({1e-3, 0.5});
  ASSERT_EQ(slow.size(), 3u);
  EXPECT_DOUBLE_EQ(slow[0], 1e-3);
  EXPECT_DOUBLE_EQ(slow[2], 0.1);
}

}  // namespace
}  // namespace lp
