// The threaded live chain: whole brackets or nothing, every frame accounted for, a lost
// camera reopened without the stream stopping, slow back ends dropping whole brackets.
#include <gtest/gtest.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>

#include "eval/synthetic_scene.h"
#include "live/pipeline.h"

#include "core/warnings.h"
#include "probe/camera_unwrap.h"
#include "probe/fisheye.h"

namespace lp {
namespace {

// A bracketing camera painting a small fisheye sky; it can lose frames and die once.
class ScriptedSource : public CameraSource {
 public:
  ScriptedSource(int frames, int skip_every, int die_at, std::atomic<int>* opened, double frame_interval_s = 0.002)
      : frames_(frames), skip_every_(skip_every), die_at_(die_at), opened_(opened), interval_(frame_interval_s) {
    ++*opened_;
  }
  std::string describe() const override { return "scripted"; }
  void set_exposure_cycle(const std::vector<double>& s) override { cycle_ = s; }
  bool finished() const override { return produced_ >= frames_; }
  std::optional<CameraFrame> next(double) override {
    if (produced_ >= frames_) return std::nullopt;
    // A camera delivers at its frame rate.
    std::this_thread::sleep_for(std::chrono::duration<double>(interval_));
    const int i = produced_++;
    if (die_at_ >= 0 && i == die_at_ && *opened_ == 1) throw CameraLost("camera unplugged");
    if (skip_every_ > 0 && i % skip_every_ == skip_every_ - 1) {
      ++seq_;  // a frame lost on the wire: the next one breaks its bracket
      return next(0);
    }
    CameraFrame f;
    const size_t k = cycle_.empty() ? 0 : size_t(seq_ % int64_t(cycle_.size()));
    f.exposure_s = cycle_.empty() ? 1.0 : std::max(cycle_[k], shortest_s);
    if (no_exposure_read_back) f.exposure_s = 0;
    f.bracket_index = cycle_.empty() ? -1 : int(k);
    f.sequence = seq_++;
    f.image.width = 64;
    f.image.height = 64;
    f.image.rgb.assign(64 * 64 * 3, float(std::min(1.0, 0.3 * f.exposure_s / 0.01)));
    f.gain_db = gain_db;
    f.image.vignetting_corrected = vignetting_corrected;
    return f;
  }

  double gain_db = 0;  // every frame's
  bool vignetting_corrected = false;  // frames recorded as corrected already (a replayed fused probe)
  double shortest_s = 0;  // a time asked below it is taken at it, as a camera clamps
  bool no_exposure_read_back = false;

 private:
  int frames_, skip_every_, die_at_;
  std::atomic<int>* opened_;
  double interval_;
  int produced_ = 0;
  int64_t seq_ = 0;
  std::vector<double> cycle_;
};

LivePipelineOptions options() {
  LivePipelineOptions o;
  o.exposure_cycle = {0.001, 0.004, 0.016};
  o.layout = Layout::Hemisphere;
  o.width = 90;
  o.height = 23;
  o.sampling.method = Method::Pharr;
  o.sampling.count = 16;
  o.sampling.sampler.upper_only = true;
  return o;
}

TEST(LivePipeline, EveryFrameIsProcessedInAWholeBracketOrCountedAsDropped) {
  std::atomic<int> opened{0};
  std::atomic<int> published{0};
  LivePipeline p([&] { return std::make_unique<ScriptedSource>(300, 10, -1, &opened); }, options(),
                 [&](const LightList& l, std::shared_ptr<const EnvMap>) {
                   EXPECT_EQ(l.lights.size(), 16u);
                   ++published;
                 });
  p.start();
  p.wait();
  const LiveStats s = p.stats();
  EXPECT_EQ(s.frames_in, 300u - 30u);  // every 10th frame lost on the wire
  EXPECT_EQ(uint64_t(published.load()), s.brackets_processed);
  // Frames in = 3 x (processed + dropped whole) + frames of broken brackets.
  EXPECT_EQ(s.frames_in, 3 * (s.brackets_processed + s.brackets_dropped) + s.frames_dropped_partial);
  EXPECT_GT(s.frames_dropped_partial, 0u);
  EXPECT_GT(s.brackets_processed, 40u);
}

// A camera asked for a time below its shortest takes its shortest: two frames of a bracket at
// one exposure, which check_bracket refuses. Every bracket was dropped and the stream served
// no light; now the repeated exposure is used once, said in one warning. A frame whose
// exposure is not read back is not fused at a guessed 1 s: its bracket is dropped, saying so.
TEST(LivePipeline, AnExposureTheCameraClampsIsUsedOnceAndAnUnreportedOneIsNotGuessed) {
  std::vector<std::string> warnings;
  const WarningSink before = set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  std::atomic<int> opened{0}, published{0};
  auto unhurried = options();
  unhurried.queue_brackets = 1000;  // nothing dropped for a slow back end (a sanitizer build on a busy machine)
  LivePipeline clamped(
      [&] {
        auto s = std::make_unique<ScriptedSource>(60, 0, -1, &opened);
        s->shortest_s = 0.004;  // the cycle asks 0.001, 0.004, 0.016
        return s;
      },
      unhurried, [&](const LightList&, std::shared_ptr<const EnvMap>) { ++published; });
  clamped.start();
  clamped.wait();
  set_warning_sink(before);
  EXPECT_EQ(clamped.stats().brackets_processed, 20u) << clamped.stats().last_error;
  EXPECT_EQ(clamped.stats().brackets_dropped, 0u);
  EXPECT_EQ(published.load(), 20);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "scripted: two frames of a bracket came back at one exposure (0.004 s): the camera cannot take "
                         "a time it was asked for; each exposure is used once");
  LivePipeline unknown(
      [&] {
        auto s = std::make_unique<ScriptedSource>(30, 0, -1, &opened);
        s->no_exposure_read_back = true;
        return s;
      },
      options(), [&](const LightList&, std::shared_ptr<const EnvMap>) { ++published; });
  unknown.start();
  unknown.wait();
  EXPECT_EQ(unknown.stats().brackets_processed, 0u);
  EXPECT_EQ(unknown.stats().brackets_dropped, 10u);
  EXPECT_NE(unknown.stats().last_error.find("a bracket frame came back without its exposure time"), std::string::npos)
      << unknown.stats().last_error;
}

// The published map records the probe rotation it was unwrapped with (CONVENTIONS.md), as
// `probe unwrap` does: what /probe.exr and the recorder write.
TEST(LivePipeline, ThePublishedMapRecordsTheProbeRotation) {
  std::atomic<int> opened{0};
  auto o = options();
  o.world_from_probe = rotation_from_yaw_pitch_roll_deg(45, 0, 0);
  std::mutex m;
  std::optional<Mat3> seen;
  int maps = 0;
  LivePipeline p([&] { return std::make_unique<ScriptedSource>(30, 0, -1, &opened); }, o,
                 [&](const LightList&, std::shared_ptr<const EnvMap> map) {
                   const std::lock_guard lock(m);
                   ASSERT_TRUE(map);
                   seen = map->world_from_probe;
                   ++maps;
                 });
  p.start();
  p.wait();
  ASSERT_GT(maps, 0);
  ASSERT_TRUE(seen.has_value());
  EXPECT_EQ(seen->m, o.world_from_probe.m);
}

// A camera whose gain is in its own steps (GenICam's GainRaw) reports NaN: frames are divided
// by the time alone, as at 0 dB, and the stream says so once (Aravis' raw 120 was read as
// 120 dB and divided every frame by 10^6).
TEST(LivePipeline, AGainNotInDecibelsIsDividedOutAsNoneAndSaidOnce) {
  auto power_with = [](double gain_db, std::vector<std::string>* warnings) {
    std::atomic<int> opened{0};
    std::mutex m;
    double power = 0;
    const WarningSink before = set_warning_sink([&](const std::string& line) {
      const std::lock_guard lock(m);
      warnings->push_back(line);
    });
    LivePipeline p(
        [&] {
          auto source = std::make_unique<ScriptedSource>(30, 0, -1, &opened);
          source->gain_db = gain_db;
          return source;
        },
        options(), [&](const LightList& l, std::shared_ptr<const EnvMap>) {
          const std::lock_guard lock(m);
          power = 0;
          for (const Light& light : l.lights) power += light.rgb[1];
        });
    p.start();
    p.wait();
    set_warning_sink(before);
    return power;
  };
  std::vector<std::string> none, raw;
  const double at_0db = power_with(0.0, &none);
  const double unknown = power_with(NAN, &raw);
  ASSERT_GT(at_0db, 0);
  EXPECT_NEAR(unknown / at_0db, 1.0, 1e-6);
  EXPECT_TRUE(none.empty());
  ASSERT_EQ(raw.size(), 1u);
  EXPECT_NE(raw[0].find("scripted: the camera's gain is not in dB"), std::string::npos) << raw[0];
  EXPECT_NEAR(power_with(20 * std::log10(2.0), &none) / at_0db, 0.5, 1e-4);  // a known gain divides
}

// A camera whose frames hold a bright disc (the lens's image circle) on black.
class DiscSource : public CameraSource {
 public:
  explicit DiscSource(int frames) : frames_(frames) {}
  std::string describe() const override { return "disc"; }
  void set_exposure_cycle(const std::vector<double>&) override {}
  bool finished() const override { return produced_ >= frames_; }
  std::optional<CameraFrame> next(double) override {
    if (produced_ >= frames_) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    CameraFrame f;
    f.exposure_s = 1.0;
    f.sequence = produced_++;
    f.image.width = f.image.height = 64;
    for (int y = 0; y < 64; ++y)
      for (int x = 0; x < 64; ++x) {
        const double dx = x + 0.5 - 32, dy = y + 0.5 - 32;
        const float v = dx * dx + dy * dy <= 24.0 * 24.0 ? 0.6f : 0.0f;
        f.image.rgb.insert(f.image.rgb.end(), {v, v, v});
      }
    return f;
  }

 private:
  int frames_, produced_ = 0;
};

// Through a calibrated lens without --fov, the stream masked at the default 180 deg: a 150
// deg lens's black surround, 75 to 90 deg off axis, streamed as valid dark sky (and a 190 deg
// lens lost its last 5 deg). The circle found in the frame bounds it now, as probe unwrap
// does. The disc is a 150 deg lens's circle (r 24 px at 75 deg).
TEST(LivePipeline, ACalibratedLensIsBoundedByItsImageCircle) {
  auto valid_share = [](double fov_deg, bool fov_given) {
    LivePipelineOptions o = options();
    o.exposure_cycle = {};
    o.layout = Layout::LatLong;
    o.width = 180;
    o.height = 90;
    o.camera = camera_model_from_fisheye(equidistant_fisheye(64, 64, 180));
    const double f = 24 / (75 * M_PI / 180);
    o.camera->intrinsics = {f, f, 32, 32, 0, 0, 0, 0};  // pixel centres at +0.5: the disc's centre is 32
    o.fov_deg = fov_deg;
    o.fov_given = fov_given;
    std::mutex m;
    double share = 0;
    LivePipeline p([&] { return std::make_unique<DiscSource>(4); }, o, [&](const LightList&, std::shared_ptr<const EnvMap> map) {
      const std::lock_guard lock(m);
      size_t valid = 0;
      for (size_t i = 0; i < map->pixel_count(); ++i) valid += map->valid.empty() || map->valid[i];
      share = double(valid) / double(map->pixel_count());
    });
    p.start();
    p.wait();
    return share;
  };
  const double by_fov = valid_share(150, true), by_circle = valid_share(180, false);
  EXPECT_NEAR(by_fov, 75.0 / 180, 0.02);
  // Within the circle, less its 1 px soft edge (4 deg here); at 180 deg it was 90 / 180.
  EXPECT_LE(by_circle, by_fov + 0.005);
  EXPECT_GT(by_circle, by_fov - 0.04);
}

// Codes of another colour space (a replayed photo's ICC profile) are turned to Rec. 709 in
// every published map; replayed photos in Display P3 streamed as if sRGB.
TEST(LivePipeline, TheFramesColourMatrixTurnsEveryMap) {
  auto ratios = [](const std::optional<std::array<double, 9>>& matrix) {
    std::atomic<int> opened{0};
    auto o = options();
    o.to_rec709 = matrix;
    std::mutex m;
    std::array<double, 2> r_and_b_over_g{0, 0};
    LivePipeline p([&] { return std::make_unique<ScriptedSource>(30, 0, -1, &opened); }, o,
                   [&](const LightList&, std::shared_ptr<const EnvMap> map) {
                     const std::lock_guard lock(m);
                     for (size_t i = 0; i < map->pixel_count(); ++i)
                       if ((map->valid.empty() || map->valid[i]) && map->rgb[3 * i + 1] > 0) {
                         r_and_b_over_g = {map->rgb[3 * i] / map->rgb[3 * i + 1], map->rgb[3 * i + 2] / map->rgb[3 * i + 1]};
                         break;
                       }
                   });
    p.start();
    p.wait();
    return r_and_b_over_g;
  };
  const auto grey = ratios(std::nullopt);  // the source paints R = G = B
  EXPECT_NEAR(grey[0], 1.0, 1e-5);
  EXPECT_NEAR(grey[1], 1.0, 1e-5);
  const auto turned = ratios(std::array<double, 9>{2, 0, 0, 0, 1, 0, 0, 0, 0.5});
  EXPECT_NEAR(turned[0], 2.0, 1e-5);
  EXPECT_NEAR(turned[1], 0.5, 1e-5);
}

// The lens's falloff is divided out where each map pixel was read: uniform frames through
// V = 1 - 0.5 r^2 (r over the 64 x 64 frame's half-diagonal) give a map that rises from the
// zenith (the frame's centre, V = 1) to the horizon (the 180-degree circle's rim, 32 px out:
// V = 1 - 0.5 (32 / 45.25)^2 = 0.75).
TEST(LivePipeline, TheLensVignettingIsDividedOutOfEveryMap) {
  auto maps = [](std::optional<VignettingModel> vignetting, bool* corrected) {
    std::atomic<int> opened{0};
    auto o = options();
    o.vignetting = vignetting;
    o.vignetting_file = "lens.json";
    std::mutex m;
    std::vector<float> last;
    LivePipeline p([&] { return std::make_unique<ScriptedSource>(30, 0, -1, &opened); }, o,
                   [&](const LightList&, std::shared_ptr<const EnvMap> map) {
                     const std::lock_guard lock(m);
                     last.assign(map->pixel_count(), std::nanf(""));
                     for (size_t i = 0; i < map->pixel_count(); ++i)
                       if (map->is_valid(i)) last[i] = map->rgb[3 * i + 1];
                     *corrected = map->vignetting_corrected;
                   });
    p.start();
    p.wait();
    EXPECT_EQ(p.stats().last_error, "");
    return last;
  };
  VignettingModel v;
  v.image_width = v.image_height = 64;
  v.centre = {31.5, 31.5};
  v.radius_px = 0.5 * std::hypot(64.0, 64.0);
  v.k = {-0.5};
  v.terms = 1;
  v.max_radius = 1;
  bool plain_corrected = true, corrected = false;
  const std::vector<float> plain = maps(std::nullopt, &plain_corrected), fixed = maps(v, &corrected);
  EXPECT_FALSE(plain_corrected);
  EXPECT_TRUE(corrected);
  ASSERT_EQ(plain.size(), fixed.size());
  double lowest = 1e9, highest = 0;
  for (size_t i = 0; i < plain.size(); ++i)
    if (std::isfinite(plain[i]) && plain[i] > 0) {
      lowest = std::min(lowest, double(fixed[i] / plain[i]));
      highest = std::max(highest, double(fixed[i] / plain[i]));
    }
  EXPECT_NEAR(lowest, 1.0, 0.01);       // the zenith row, near the frame's centre
  EXPECT_NEAR(highest, 1 / 0.75, 0.02);  // the horizon row, at the circle's rim

  v.image_width = 80;  // measured on another camera: every bracket is dropped, naming the file
  std::atomic<int> opened{0};
  auto o = options();
  o.vignetting = v;
  o.vignetting_file = "lens.json";
  LivePipeline p([&] { return std::make_unique<ScriptedSource>(12, 0, -1, &opened); }, o,
                 [&](const LightList&, std::shared_ptr<const EnvMap>) {});
  p.start();
  p.wait();
  EXPECT_EQ(p.stats().last_error, "lens.json: vignetting measured on 80x64 images, this one is 64x64");

  // Frames corrected already (replayed probes of hdr fuse --vignetting) are not corrected again.
  v.image_width = 64;
  o.vignetting = v;
  std::atomic<int> published{0};
  LivePipeline again(
      [&] {
        auto source = std::make_unique<ScriptedSource>(12, 0, -1, &opened);
        source->vignetting_corrected = true;
        return source;
      },
      o, [&](const LightList&, std::shared_ptr<const EnvMap>) { ++published; });
  again.start();
  again.wait();
  EXPECT_EQ(published.load(), 0);
  EXPECT_EQ(again.stats().last_error,
            "scripted: the frames' vignetting is corrected already (hdr fuse --vignetting); --vignetting lens.json would "
            "divide it out twice");
}

TEST(LivePipeline, ACameraModelOfAnotherSizeDropsEveryBracketNamingItsFile) {
  std::atomic<int> opened{0};
  std::atomic<int> published{0};
  auto o = options();
  o.camera = camera_model_from_fisheye(equidistant_fisheye(80, 60, 180));  // the frames are 64x64
  o.camera_file = "rig.yaml";
  LivePipeline p([&] { return std::make_unique<ScriptedSource>(30, 0, -1, &opened); }, o,
                 [&](const LightList&, std::shared_ptr<const EnvMap>) { ++published; });
  p.start();
  p.wait();
  const LiveStats s = p.stats();
  EXPECT_EQ(published.load(), 0);
  EXPECT_EQ(s.brackets_dropped, 10u);
  EXPECT_EQ(s.last_error, "rig.yaml: camera model is for 80x60, frames are 64x64");
}

TEST(LivePipeline, ALostCameraIsReopenedAndTheStreamGoesOn) {
  std::atomic<int> opened{0};
  std::atomic<int> published{0};
  auto o = options();
  o.reconnect_delay_s = 0.01;
  o.queue_brackets = 1000;  // the count below is the reopened camera's, not a busy machine's drops
  LivePipeline p([&] { return std::make_unique<ScriptedSource>(90, 0, 30, &opened); }, o,
                 [&](const LightList&, std::shared_ptr<const EnvMap>) { ++published; });
  p.start();
  p.wait();
  EXPECT_EQ(p.stats().reconnects, 1u);
  EXPECT_EQ(opened.load(), 2);
  EXPECT_GT(published.load(), 25);  // the reopened camera's 90 frames: 30 brackets
}

TEST(LivePipeline, ASlowBackEndDropsWholeBracketsNotFrames) {
  std::atomic<int> opened{0};
  std::atomic<int> published{0};
  LivePipeline p([&] { return std::make_unique<ScriptedSource>(600, 0, -1, &opened, 0.0); }, options(),
                 [&](const LightList&, std::shared_ptr<const EnvMap>) {
                   std::this_thread::sleep_for(std::chrono::milliseconds(20));
                   ++published;
                 });
  p.start();
  p.wait();
  const LiveStats s = p.stats();
  EXPECT_GT(s.brackets_dropped, 0u);
  EXPECT_EQ(s.frames_dropped_partial, 0u);
  EXPECT_EQ(s.frames_in, 3 * (s.brackets_processed + s.brackets_dropped));
  EXPECT_NE(p.metrics().find("lightprobe_brackets_dropped_total"), std::string::npos);
}

}  // namespace
}  // namespace lp
