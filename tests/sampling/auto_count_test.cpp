// --n auto: the fewest lights that reach a diffuse error, found by bracketing + bisection.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "core/accuracy.h"
#include "core/error.h"
#include "eval/synthetic_scene.h"
#include "sampling/auto_count.h"

namespace lp {
namespace {

struct Fixture {
  EnvMap map = render_scene(describe_scene(), Layout::LatLong, 256, 128);
  AccuracyReference reference = [this] {
    AccuracyOptions o;
    o.shadowed = false;
    return make_accuracy_reference(map, o);
  }();
};

TEST(AutoCount, FindsACountThatMeetsTheTargetWhileOneLessMissesIt) {
  Fixture f;
  auto sampler = make_sampler(Method::Pharr);
  sampler->prepare(f.map);
  AutoCountOptions options;
  options.target_error = 0.02;
  const AutoCountResult r = choose_light_count(*sampler, f.reference, options);
  ASSERT_TRUE(r.reached);
  EXPECT_EQ(int(r.lights.size()), r.count);
  EXPECT_LE(light_error(f.reference, sampler->place(r.count)).diffuse, 0.02);
  // Bisection ends on a miss just below the answer.
  EXPECT_GT(light_error(f.reference, sampler->place(r.count - 1)).diffuse, 0.02);
  // Far fewer evaluations than trying every count.
  EXPECT_LE(r.evaluations, 2 * int(std::log2(double(r.count))) + 4);
}

TEST(AutoCount, ATighterTargetNeedsMoreLights) {
  Fixture f;
  auto sampler = make_sampler(Method::Q2Tree);
  sampler->prepare(f.map);
  AutoCountOptions loose, tight;
  loose.target_error = 0.05;
  tight.target_error = 0.002;
  const auto a = choose_light_count(*sampler, f.reference, loose);
  const auto b = choose_light_count(*sampler, f.reference, tight);
  ASSERT_TRUE(a.reached && b.reached);
  EXPECT_LT(a.count, b.count);
  EXPECT_LE(b.error, 0.002);
}

TEST(AutoCount, AnUnreachableTargetIsReportedNotFaked) {
  Fixture f;
  auto sampler = make_sampler(Method::Pharr);
  sampler->prepare(f.map);
  AutoCountOptions options;
  options.target_error = 1e-9;
  options.max_count = 64;
  const auto r = choose_light_count(*sampler, f.reference, options);
  EXPECT_FALSE(r.reached);
  EXPECT_GT(r.error, 1e-9);
  options.target_error = 0;
  EXPECT_THROW(choose_light_count(*sampler, f.reference, options), InputError);
}

// The measure held under the target (issue 20 item 2): a diffuse target leaves the
// glossy s=100 error far above it; holding glossy100 (or the worst of all four) buys the
// lights that bring it down. Every error is rescored against a full reference built apart.
TEST(AutoCount, TheChosenMeasureIsHeldUnderTheTargetAndCostsLights) {
  Fixture f;
  const AccuracyReference full = make_accuracy_reference(f.map);  // all four measures
  auto sampler = make_sampler(Method::Q2Tree);
  sampler->prepare(f.map);
  auto chosen = [&](ErrorMeasure m, double target) {
    AutoCountOptions o;
    o.target_error = target;
    o.measure = m;
    const AccuracyReference reference = make_accuracy_reference(f.map, reference_options_for(m));
    const AutoCountResult r = choose_light_count(*sampler, reference, o);
    EXPECT_TRUE(r.reached) << to_string(m);
    return std::make_pair(r, light_error(full, r.lights));
  };
  const auto [diffuse, diffuse_e] = chosen(ErrorMeasure::Diffuse, 0.05);
  const auto [glossy, glossy_e] = chosen(ErrorMeasure::Glossy100, 0.05);
  const auto [worst, worst_e] = chosen(ErrorMeasure::Worst, 0.05);
  std::printf("  5 %%: diffuse %d lights (glossy100 %.3f), glossy100 %d lights (%.4f), worst %d lights\n", diffuse.count,
              diffuse_e.glossy[1], glossy.count, glossy_e.glossy[1], worst.count);
  EXPECT_GT(diffuse_e.glossy[1], 0.05);  // what a diffuse target leaves for a shiny material
  EXPECT_LE(glossy_e.glossy[1], 0.05);
  EXPECT_NEAR(glossy.error, glossy_e.glossy[1], 1e-9);
  EXPECT_GT(glossy.count, diffuse.count);
  for (double e : {worst_e.diffuse, worst_e.glossy[0], worst_e.glossy[1], worst_e.shadowed}) EXPECT_LE(e, 0.05);
  EXPECT_GE(worst.count, glossy.count / 2);  // bisection over a non-monotone error: not always >=
}

// A frame budget's ceiling (FrameBudget through FramePipeline): the tracker searches no
// further than the ceiling, says the target was missed, and goes back up when it is lifted.
TEST(AutoCount, ATrackerUnderACeilingStopsThereAndRecoversWhenItLifts) {
  Fixture f;
  auto sampler = make_sampler(Method::Pharr);
  sampler->prepare(f.map);
  AutoCountOptions o;
  o.target_error = 0.002;
  AutoCountTracker tracker(o);
  const AutoCountResult free = tracker.update(*sampler, f.reference);
  ASSERT_TRUE(free.reached);
  ASSERT_GT(free.count, 64);
  tracker.limit(32);
  const AutoCountResult capped = tracker.update(*sampler, f.reference);
  EXPECT_EQ(capped.count, 32);
  EXPECT_FALSE(capped.reached);
  EXPECT_LE(capped.evaluations, 3);  // the held count and one search step: no placement beyond the cap
  EXPECT_NEAR(capped.error, light_error(f.reference, sampler->place(32)).diffuse, 1e-12);
  tracker.limit(1 << 20);  // lifted (never above the options' max_count)
  const AutoCountResult lifted = tracker.update(*sampler, f.reference);
  EXPECT_TRUE(lifted.reached);
  EXPECT_LE(lifted.error, 0.002);
}

TEST(AutoCount, MeasuresAreNamedAndAReferenceWithoutOneIsRefused) {
  for (ErrorMeasure m : {ErrorMeasure::Diffuse, ErrorMeasure::Glossy10, ErrorMeasure::Glossy100, ErrorMeasure::Shadowed,
                         ErrorMeasure::Worst})
    EXPECT_EQ(error_measure_from_string(to_string(m)), m);
  try {
    error_measure_from_string("specular");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "--error-measure: unknown measure 'specular' (diffuse, glossy10, glossy100, shadowed, worst)");
  }
  LightError e;
  e.diffuse = 0.1;
  e.glossy = {0.3};
  e.shadowed = 0.2;
  const AccuracyOptions only10 = reference_options_for(ErrorMeasure::Glossy10);
  EXPECT_EQ(measured_error(e, only10, ErrorMeasure::Glossy10), 0.3);
  EXPECT_THROW(measured_error(e, only10, ErrorMeasure::Glossy100), InputError);
  EXPECT_THROW(measured_error(e, only10, ErrorMeasure::Shadowed), InputError);
  EXPECT_EQ(measured_error(e, only10, ErrorMeasure::Worst), 0.3);  // shadowed off: not counted
  AccuracyOptions all;
  e.glossy = {0.05, 0.15};
  e.shadowed = 0.4;
  EXPECT_EQ(measured_error(e, all, ErrorMeasure::Worst), 0.4);
}

}  // namespace
}  // namespace lp

namespace lp {
namespace {

TEST(AutoCountTracker, RisesAtOnceButFallsOnlyAfterTheHoldTime) {
  // Two scenes: a plain sky needs few lights for 2 %; with sun, windows and lamp many more.
  SceneOptions calm_options;
  calm_options.sun_rgb = {0, 0, 0};
  calm_options.area_lights = false;
  const EnvMap calm = render_scene(describe_scene(calm_options), Layout::LatLong, 256, 128);
  const EnvMap sunny = render_scene(describe_scene(), Layout::LatLong, 256, 128);
  AccuracyOptions ao;
  ao.shadowed = false;
  const AccuracyReference calm_ref = make_accuracy_reference(calm, ao), sunny_ref = make_accuracy_reference(sunny, ao);

  auto sampler = make_sampler(Method::Pharr);
  AutoCountOptions options;
  options.target_error = 0.02;
  AutoCountHysteresis hysteresis;
  hysteresis.hold_frames = 5;
  AutoCountTracker tracker(options, hysteresis);

  std::vector<int> counts;
  auto frame = [&](const EnvMap& map, const AccuracyReference& ref) {
    sampler->prepare(map);
    const AutoCountResult r = tracker.update(*sampler, ref);
    EXPECT_LE(r.error, 0.02);  // every frame meets the target
    counts.push_back(r.count);
  };
  for (int i = 0; i < 4; ++i) frame(calm, calm_ref);
  for (int i = 0; i < 4; ++i) frame(sunny, sunny_ref);
  for (int i = 0; i < 12; ++i) frame(calm, calm_ref);

  // Steady on a static scene: no flicker of the count.
  for (int i = 1; i < 4; ++i) EXPECT_EQ(counts[size_t(i)], counts[0]);
  // Rises on the very frame the sun appears, and stays while it is there.
  EXPECT_GT(counts[4], counts[3]);
  for (int i = 5; i < 8; ++i) EXPECT_EQ(counts[size_t(i)], counts[4]);
  // Back to calm: the count is held for the hold time, then falls.
  for (int i = 8; i < 8 + hysteresis.hold_frames - 1; ++i) EXPECT_EQ(counts[size_t(i)], counts[4]) << i;
  EXPECT_LT(counts.back(), counts[4]);
}

}  // namespace
}  // namespace lp
