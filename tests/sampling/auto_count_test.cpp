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
  options.target_diffuse_error = 0.02;
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
  loose.target_diffuse_error = 0.05;
  tight.target_diffuse_error = 0.002;
  const auto a = choose_light_count(*sampler, f.reference, loose);
  const auto b = choose_light_count(*sampler, f.reference, tight);
  ASSERT_TRUE(a.reached && b.reached);
  EXPECT_LT(a.count, b.count);
  EXPECT_LE(b.diffuse_error, 0.002);
}

TEST(AutoCount, AnUnreachableTargetIsReportedNotFaked) {
  Fixture f;
  auto sampler = make_sampler(Method::Pharr);
  sampler->prepare(f.map);
  AutoCountOptions options;
  options.target_diffuse_error = 1e-9;
  options.max_count = 64;
  const auto r = choose_light_count(*sampler, f.reference, options);
  EXPECT_FALSE(r.reached);
  EXPECT_GT(r.diffuse_error, 1e-9);
  options.target_diffuse_error = 0;
  EXPECT_THROW(choose_light_count(*sampler, f.reference, options), InputError);
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
  options.target_diffuse_error = 0.02;
  AutoCountHysteresis hysteresis;
  hysteresis.hold_frames = 5;
  AutoCountTracker tracker(options, hysteresis);

  std::vector<int> counts;
  auto frame = [&](const EnvMap& map, const AccuracyReference& ref) {
    sampler->prepare(map);
    const AutoCountResult r = tracker.update(*sampler, ref);
    EXPECT_LE(r.diffuse_error, 0.02);  // every frame meets the target
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
