// Auto-bracketing (hdr/auto_bracket.h): the fewest exposures that cover a scene of known
// radiance, checked pixel by pixel against the coverage rule; camera limits; metering
// through a bracket that clipped; a planner that follows a scene without oscillating.
#include "hdr/auto_bracket.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/error.h"
#include "hdr/merge.h"
#include "hdr/synthetic_bracket.h"

namespace lp {
namespace {

// Log-uniform radiance from low to high (both ends included).
MeteredScene log_uniform(double low, double high, int n = 2000) {
  MeteredScene s;
  for (int i = 0; i < n; ++i) s.radiance.push_back(float(low * std::pow(high / low, double(i) / (n - 1))));
  return s;
}

// The rule of the header, independently: some exposure reads the pixel in [min, max] code.
bool covered(double radiance, const std::vector<double>& times, const ExposureWindow& w) {
  for (double t : times)
    if (radiance * t >= w.x_low * (1 - 1e-9) && radiance * t <= w.x_high * (1 + 1e-9)) return true;
  return false;
}

TEST(AutoBracket, LinearWindowIsTheCodesThroughTheResponse) {
  // 8-bit linear response: g(z) = ln(level / 128), level = round(code * 255).
  const ExposureWindow w = usable_exposure_window(linear_response(256));
  EXPECT_NEAR(w.x_low, 26.0 / 128, 1e-6);    // 0.1 * 255 = 25.5 -> 26
  EXPECT_NEAR(w.x_high, 242.0 / 128, 1e-6);  // 0.95 * 255 = 242.25 -> 242
  EXPECT_NEAR(w.x_clipped, 247.0 / 128, 1e-6);
  EXPECT_NEAR(w.x_black, 8.0 / 128, 1e-6);
  EXPECT_THROW(usable_exposure_window(linear_response(256), {0.5, 0.4}), InputError);
}

TEST(AutoBracket, FewestExposuresCoverEveryPixelOfAKnownRange) {
  const ExposureWindow w = usable_exposure_window(linear_response(256));
  const double window = w.x_high / w.x_low;  // 9.31
  AutoBracketOptions o;
  o.dark_fraction = 0;
  ExposureLimits many;
  many.max_exposures = 12;
  many.max_seconds = 10;
  for (double range : {3.0, 30.0, 1e3, 1e5}) {
    const MeteredScene scene = log_uniform(0.5, 0.5 * range);
    const BracketPlan p = plan_bracket(scene, w, many, o);
    for (float v : scene.radiance) ASSERT_TRUE(covered(v, p.exposure_seconds, w)) << range << " at " << v;
    // With the headroom, the span to cover is range * headroom^2; n exposures whose windows
    // overlap by the overlap factor cover at most window * (window / overlap)^(n - 1), so
    // n - 1 cannot do it.
    const double span = range * o.headroom * o.headroom;
    const int n = int(p.exposure_seconds.size());
    EXPECT_GT(span, window * std::pow(window / o.overlap, n - 2)) << range;
    EXPECT_EQ(p.covered_fraction, 1.0);
    EXPECT_EQ(p.limit, BracketLimit::None);
    EXPECT_NEAR(p.scene_stops, std::log2(range), 1e-5);
    EXPECT_LE(p.cover_low, 0.5 / o.headroom * 1.0001);
    EXPECT_GE(p.cover_high, 0.5 * range * o.headroom * 0.9999);
  }
  // Concretely, 1 + ceil(ln(range * 2.83^2 / 9.31) / ln(9.31 / 1.5)) (the first window, then
  // steps of 6.21x): a 3x room (1.6 stops) takes 2 exposures, a 1e4 scene (13.3 stops) 6.
  EXPECT_EQ(plan_bracket(log_uniform(0.5, 1.5), w, many, o).exposure_seconds.size(), 2u);
  EXPECT_EQ(plan_bracket(log_uniform(0.5, 5e3), w, many, o).exposure_seconds.size(), 6u);
}

TEST(AutoBracket, TheDarkestPercentMayStayUnderTheFloor) {
  const ExposureWindow w = usable_exposure_window(linear_response(256));
  MeteredScene scene = log_uniform(1, 2, 990);
  for (int i = 0; i < 10; ++i) scene.radiance.push_back(1e-4f);  // 1 % dead pixels
  const BracketPlan p = plan_bracket(scene, w, {});
  EXPECT_EQ(p.exposure_seconds.size(), 2u);  // not 6 for the dead pixels
  EXPECT_NEAR(p.covered_fraction, 0.99, 1e-9);
}

TEST(AutoBracket, CameraLimitsGiveUpTheDarkEndFirstAndSaySo) {
  const ExposureWindow w = usable_exposure_window(linear_response(256));
  const MeteredScene scene = log_uniform(0.5, 5e4);
  ExposureLimits few;
  few.max_exposures = 3;
  const BracketPlan p = plan_bracket(scene, w, few);
  ASSERT_EQ(p.exposure_seconds.size(), 3u);
  EXPECT_EQ(p.limit, BracketLimit::DarkMaxExposures);
  EXPECT_TRUE(covered(5e4, p.exposure_seconds, w));   // the sun is kept
  EXPECT_FALSE(covered(0.5, p.exposure_seconds, w));  // the shadows are not
  EXPECT_NE(p.reason.find("3 exposures at most"), std::string::npos) << p.reason;
  ExposureLimits slow;
  slow.min_seconds = 1e-3;  // the sun needs 1.89 / (5e4 * 2.83) = 1.3e-5 s
  const BracketPlan q = plan_bracket(scene, w, slow);
  EXPECT_EQ(q.limit, BracketLimit::BrightShortest);
  EXPECT_DOUBLE_EQ(q.exposure_seconds.front(), 1e-3);
  EXPECT_LT(q.covered_fraction, 1.0);
  EXPECT_NE(q.reason.find("bright end clipped"), std::string::npos) << q.reason;
  ExposureLimits two;
  two.min_exposures = 2;
  EXPECT_EQ(plan_bracket(log_uniform(1, 1.1), w, two).exposure_seconds.size(), 2u);
  EXPECT_EQ(plan_bracket(log_uniform(1, 1.1), w, {}).exposure_seconds.size(), 1u);
  two.min_exposures = 9;
  EXPECT_THROW(plan_bracket(scene, w, two), InputError);
  EXPECT_THROW(plan_bracket(MeteredScene{}, w, {}), InputError);
}

// A scene metered through a real merge: a sun clipped in every frame of the metering
// bracket is only a lower bound, and the plan reaches past it.
TEST(AutoBracket, AClippedSunInTheMeteringBracketIsLookedForFurther) {
  RgbImage truth;
  truth.width = 64, truth.height = 32;
  truth.rgb.assign(64 * 32 * 3, 1.0f);
  for (int y = 10; y < 14; ++y)
    for (int x = 10; x < 14; ++x)
      for (int c = 0; c < 3; ++c) truth.rgb[3 * (y * 64 + x) + c] = 2e4f;
  SyntheticBracketOptions so;
  so.exposure_seconds = {0.05, 0.4};  // the sun clips in both
  so.exposure_scale = 1;
  so.add_noise = false;
  const SyntheticBracket b = make_synthetic_bracket(truth, so);
  Bracket bracket{b.frames, b.exposure_seconds, 8, {}};
  CameraResponse truth_response;
  truth_response.levels = 256;
  truth_response.log_exposure = b.true_log_exposure;
  const RgbImage fused = merge_bracket(bracket, truth_response);
  const ExposureWindow w = usable_exposure_window(truth_response);
  const BracketPlan p = plan_bracket(meter_image(fused, b.exposure_seconds), w, {});
  EXPECT_TRUE(p.bright_clipped_in_meter);
  // The sun read at most 1 / 0.05 = 20; the plan reaches 16x further, times the headroom.
  EXPECT_GE(p.cover_high, 20 * 16 * AutoBracketOptions{}.headroom * 0.99);
  EXPECT_NE(p.reason.find("guessed, clipped"), std::string::npos);
  // The next bracket meters the sun; the planner then settles on it.
  AutoBracketPlanner planner(w, {});
  ASSERT_TRUE(planner.update(meter_image(fused, b.exposure_seconds)));
  for (int round = 0; round < 4; ++round) {
    so.exposure_seconds = planner.plan().exposure_seconds;
    const SyntheticBracket next = make_synthetic_bracket(truth, so);
    const RgbImage again = merge_bracket(Bracket{next.frames, next.exposure_seconds, 8, {}}, truth_response);
    planner.update(meter_image(again, next.exposure_seconds));
  }
  EXPECT_FALSE(planner.plan().bright_clipped_in_meter);
  EXPECT_NEAR(planner.plan().scene_high, 2e4, 2e4 * 0.02);
  EXPECT_EQ(planner.plan().covered_fraction, 1.0);
  EXPECT_TRUE(covered(2e4, planner.plan().exposure_seconds, w));
}

// A steady scene with 10 % per-pixel noise from frame to frame: one plan, never changed.
TEST(AutoBracketPlanner, ANoisySteadySceneKeepsOnePlan) {
  const ExposureWindow w = usable_exposure_window(linear_response(256));
  AutoBracketPlanner planner(w, {});
  std::mt19937 rng(7);
  std::lognormal_distribution<double> noise(0, 0.1);
  const MeteredScene base = log_uniform(0.3, 300);
  for (int frame = 0; frame < 300; ++frame) {
    MeteredScene s = base;
    for (float& v : s.radiance) v = float(v * noise(rng));
    const bool changed = planner.update(s);
    EXPECT_EQ(changed, frame == 0) << frame << ": " << planner.last_decision();
  }
  EXPECT_EQ(planner.changes(), 0u);
  EXPECT_EQ(planner.last_decision(), "steady");
  EXPECT_EQ(planner.plan().covered_fraction, 1.0);
}

// A scene on the hysteresis edge: its range flips by 1.4x (half a stop) every frame, less
// than the 2x a steady plan tolerates; the plan does not follow it back and forth.
TEST(AutoBracketPlanner, ARangeFlickeringInsideTheMarginDoesNotOscillate) {
  const ExposureWindow w = usable_exposure_window(linear_response(256));
  AutoBracketPlanner planner(w, {});
  for (int frame = 0; frame < 100; ++frame) planner.update(log_uniform(1, frame % 2 ? 50 : 70));
  EXPECT_EQ(planner.changes(), 0u);
}

TEST(AutoBracketPlanner, GrowsAtOnceForALampAndShrinksWhenItGoesOff) {
  const ExposureWindow w = usable_exposure_window(linear_response(256));
  AutoBracketPlanner planner(w, {});
  planner.update(log_uniform(1, 4));
  const size_t dim = planner.plan().exposure_seconds.size();
  MeteredScene lamp = log_uniform(1, 4);
  lamp.radiance.push_back(4000);
  EXPECT_TRUE(planner.update(lamp));
  EXPECT_NE(planner.last_decision().find("bright end"), std::string::npos);
  const size_t lit = planner.plan().exposure_seconds.size();
  EXPECT_GT(lit, dim);
  EXPECT_TRUE(covered(4000, planner.plan().exposure_seconds, w));
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(planner.update(lamp));
  EXPECT_TRUE(planner.update(log_uniform(1, 4)));
  EXPECT_NE(planner.last_decision().find("range shrank"), std::string::npos);
  EXPECT_LT(planner.plan().exposure_seconds.size(), lit);
  EXPECT_EQ(planner.changes(), 2u);
}

TEST(AutoBracketPlanner, AtACameraLimitTheNoisySceneDoesNotReplanEveryFrame) {
  const ExposureWindow w = usable_exposure_window(linear_response(256));
  ExposureLimits slow;
  slow.min_seconds = 1e-2;  // the sun can never be covered
  AutoBracketPlanner planner(w, slow);
  std::mt19937 rng(3);
  std::lognormal_distribution<double> noise(0, 0.1);
  for (int frame = 0; frame < 100; ++frame) {
    MeteredScene s = log_uniform(0.5, 5e4);
    for (float& v : s.radiance) v = float(v * noise(rng));
    planner.update(s);
  }
  EXPECT_EQ(planner.changes(), 0u);
  EXPECT_EQ(planner.plan().limit, BracketLimit::BrightShortest);
}

}  // namespace
}  // namespace lp
