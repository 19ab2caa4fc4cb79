#include "eval/temporal_accuracy.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/error.h"
#include "eval/synthetic_scene.h"
#include "eval/synthetic_sequence.h"

namespace lp {
namespace {

double deg(double d) { return d * M_PI / 180.0; }

// One light per pixel: the map's own exact light list (ids = pixel indices).
std::vector<Light> pixel_lights(const EnvMap& map, double scale = 1.0) {
  std::vector<Light> out;
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const double w = pixel_solid_angle(map, i) * scale;
    const float* p = map.pixel(i);
    if (p[0] == 0 && p[1] == 0 && p[2] == 0) continue;
    out.push_back({i, pixel_direction(map, i), {p[0] * w, p[1] * w, p[2] * w}, pixel_solid_angle(map, i)});
  }
  return out;
}

// sqrt(mean_k E^2) / mean_k E: the diffuse error of lights that are all off by one factor
// (1 + a) is a times this.
double rms_over_mean(const std::vector<double>& e) {
  double sq = 0, sum = 0;
  for (double v : e) {
    sq += v * v;
    sum += v;
  }
  return std::sqrt(sq / double(e.size())) / (sum / double(e.size()));
}

const EnvMap& small_scene() {
  static const EnvMap map = render_scene(describe_scene(), Layout::LatLong, 64, 32);
  return map;
}

std::vector<EnvMap> abrupt_sequence(int frames) {
  SequenceOptions o;
  o.scenario = Scenario::AbruptSwitch;
  o.frames = frames;
  std::vector<EnvMap> maps;
  for (int k = 0; k < frames; ++k) maps.push_back(render_sequence_frame(small_scene(), o, k));
  return maps;
}

TEST(TemporalScorer, ExactLightsHaveNoFlickerNoLagAndNoErrorAcrossAnAbruptStepDown) {
  const auto maps = abrupt_sequence(12);
  TemporalScorer scorer;
  for (const EnvMap& m : maps) scorer.add_frame(m, pixel_lights(m));
  const TemporalReport r = scorer.report(6);
  EXPECT_EQ(r.frames, 12);
  EXPECT_LT(r.flicker, 1e-5);
  EXPECT_EQ(r.lag_frames, 0.0);
  EXPECT_LT(r.mean_diffuse_error, 1e-5);
  EXPECT_NEAR(r.jitter_deg, 0.0, 1e-12) << "pixel lights never move";
}

TEST(TemporalScorer, LightsOneFrameLateLagByExactlyOneFrameUpOrDown) {
  const auto maps = abrupt_sequence(12);
  for (bool reversed : {false, true}) {  // reversed: a step up at frame 6
    SCOPED_TRACE(reversed ? "step up" : "step down");
    std::vector<EnvMap> seq = maps;
    if (reversed) std::reverse(seq.begin(), seq.end());
    TemporalScorer scorer, exact;
    for (size_t t = 0; t < seq.size(); ++t) {
      scorer.add_frame(seq[t], pixel_lights(seq[t == 0 ? 0 : t - 1]));
      exact.add_frame(seq[t], pixel_lights(seq[t]));
    }
    const TemporalReport r = scorer.report(6);
    EXPECT_EQ(r.lag_frames, 1.0);
    // The late list changes one frame after the reference: at frames 6 and 7 it is off by
    // the whole step |dE_ref(6, k)|, elsewhere exact; so flicker = 2 mean_k |dE_ref(6, k)| / (11 Ebar).
    double step = 0, ebar = 0;
    const auto& before = exact.reference_irradiance(5);
    const auto& after = exact.reference_irradiance(6);
    for (size_t k = 0; k < before.size(); ++k) step += std::fabs(after[k] - before[k]) / double(before.size());
    for (int t = 0; t < 12; ++t)
      for (double e : exact.reference_irradiance(t)) ebar += e / (12.0 * double(before.size()));
    EXPECT_NEAR(r.flicker, 2 * step / (11 * ebar), 1e-5);
    EXPECT_GT(r.flicker, 0.01);
    EXPECT_EQ(exact.report(6).lag_frames, 0.0);
  }
}

TEST(TemporalScorer, LightsThatNeverFollowTheStepNeverReachIt) {
  const auto maps = abrupt_sequence(8);
  TemporalScorer scorer;
  for (const EnvMap& m : maps) scorer.add_frame(m, pixel_lights(maps[0]));
  EXPECT_TRUE(std::isinf(scorer.report(4).lag_frames));
  EXPECT_TRUE(std::isnan(scorer.report().lag_frames)) << "no step frame given";
}

TEST(TemporalScorer, LightsTurningOneDegreePerFrameJitterOneDegree) {
  // Five lights at random-ish directions, each turning about its own axis perpendicular to
  // it, by 1 deg per frame; light 4 is missing in odd frames and does not count there.
  const std::vector<double> E(256, 1.0);
  std::vector<Vec3> dirs, axes;
  for (int i = 0; i < 5; ++i) {
    dirs.push_back(direction_from_angles(deg(20 + 30 * i), deg(70 * i)));
    Vec3 a = normalize(cross(dirs.back(), normalize(Vec3{0.3, -0.5 + 0.2 * i, 0.8})));
    axes.push_back(a);
  }
  TemporalScorer scorer;
  for (int t = 0; t < 10; ++t) {
    std::vector<Light> lights;
    const double a = deg(1.0 * t);
    for (int i = 0; i < 5; ++i) {
      if (i == 4 && t % 2) continue;
      // Rodrigues about an axis perpendicular to the direction: d cos a + (axis x d) sin a.
      const Vec3 d = std::cos(a) * dirs[size_t(i)] + std::sin(a) * cross(axes[size_t(i)], dirs[size_t(i)]);
      lights.push_back({uint64_t(100 + i), d, {1, 1, 1}, 0.01});
    }
    scorer.add_frame(E, lights);
  }
  EXPECT_NEAR(scorer.report().jitter_deg, 1.0, 1e-9);
}

TEST(TemporalScorer, AlternatingTenPercentPowerAroundTheRightMeanFlickersPointTwo) {
  // Static reference (dE_ref = 0); lights (1 +- 0.1) x exact: |dE_lights(t, k)| = 0.2 E_ref(k)
  // for every t >= 1, so flicker = mean_k 0.2 E_ref(k) / mean_k E_ref(k) = 0.2 exactly,
  // while the per-frame diffuse error is 0.1 rms_k E_ref / mean_k E_ref (rel_rms divides an
  // rms by a mean).
  const EnvMap& map = small_scene();
  TemporalScorer scorer;
  for (int t = 0; t < 9; ++t) scorer.add_frame(map, pixel_lights(map, t % 2 ? 0.9 : 1.1));
  const TemporalReport r = scorer.report();
  const double ratio = rms_over_mean(scorer.reference_irradiance(0));
  EXPECT_GT(ratio, 1.0);
  EXPECT_NEAR(r.flicker, 0.2, 1e-5);
  EXPECT_NEAR(r.mean_diffuse_error, 0.1 * ratio, 1e-5);
  EXPECT_TRUE(std::isnan(r.lag_frames));

  TemporalScorer steady;  // a constant 10 % too bright: wrong, but steady
  for (int t = 0; t < 4; ++t) steady.add_frame(map, pixel_lights(map, 1.1));
  EXPECT_LT(steady.report().flicker, 1e-9);
  EXPECT_NEAR(steady.report().mean_diffuse_error, 0.1 * ratio, 1e-5);
}

TEST(TemporalScorer, StaticNoiseWithExactPerFrameLightsMeasuresTheNoiseNotTheMethod) {
  // Lights that copy each noisy frame follow the reference exactly: flicker 0 even though
  // the frames differ, while lights of the clean base flicker by the noise's own change.
  const EnvMap& base = small_scene();
  SequenceOptions o;
  o.scenario = Scenario::StaticNoise;
  TemporalScorer follow, clean;
  for (int t = 0; t < 6; ++t) {
    const EnvMap f = render_sequence_frame(base, o, t);
    follow.add_frame(f, pixel_lights(f));
    clean.add_frame(f, pixel_lights(base));
  }
  EXPECT_LT(follow.report().flicker, 1e-5);
  EXPECT_GT(clean.report().flicker, 1e-4);
  EXPECT_LT(clean.report().flicker, 0.02);
}

TEST(TemporalScorer, ReusedReferenceIrradianceScoresLikeTheMap) {
  const EnvMap& map = small_scene();
  AccuracyOptions ao;
  ao.glossy_exponents.clear();
  ao.shadowed = false;
  const AccuracyReference ref = make_accuracy_reference(map, ao);
  TemporalScorer a, b;
  const auto lights = pixel_lights(map, 1.05);
  a.add_frame(map, lights);
  b.add_frame(ref.diffuse, lights);
  EXPECT_DOUBLE_EQ(a.report().mean_diffuse_error, b.report().mean_diffuse_error);
  EXPECT_NEAR(a.report().mean_diffuse_error, 0.05 * rms_over_mean(ref.diffuse), 1e-5);
  EXPECT_TRUE(std::isnan(a.report().flicker)) << "one frame has no change to measure";
}

TEST(TemporalScorer, MisuseThrowsInputError) {
  TemporalScorer scorer(64);
  EXPECT_EQ(scorer.normals().size(), 64u);
  EXPECT_THROW(scorer.add_frame(std::vector<double>(256, 1.0), {}), InputError);
  const std::vector<Light> twice{{7, {0, 0, 1}, {1, 1, 1}, 0}, {7, {1, 0, 0}, {1, 1, 1}, 0}};
  EXPECT_THROW(scorer.add_frame(std::vector<double>(64, 1.0), twice), InputError);
  EXPECT_EQ(scorer.frames(), 0) << "a rejected frame is not kept";
  scorer.add_frame(std::vector<double>(64, 1.0), {});
  scorer.add_frame(std::vector<double>(64, 2.0), {});
  EXPECT_THROW(scorer.report(0), InputError);
  EXPECT_THROW(scorer.report(2), InputError);
  EXPECT_NO_THROW(scorer.report(1));
}

}  // namespace
}  // namespace lp
