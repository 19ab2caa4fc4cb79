// core/temporal_tonemap.h: Reinhard's world luminance and key per frame, and their
// first-order filter over time, against closed forms.
#include "core/temporal_tonemap.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "core/envmap.h"
#include "core/tonemap.h"

namespace lp {
namespace {

// A 10 x 10 latlong map: `bright` pixels of luminance hi, the rest lo (grey, so Y = value).
EnvMap two_levels(double lo, double hi, int bright) {
  EnvMap map = make_latlong(10, 5);
  map.rgb.assign(3 * 50, float(lo));
  for (int i = 0; i < bright; ++i)
    for (int c = 0; c < 3; ++c) map.pixel(size_t(i))[c] = float(hi);
  return map;
}

TEST(TemporalToneMap, FrameParametersAreReinhardsLogAverageAndAutomaticKey) {
  // One luminance: L_w = delta + Y with delta = 1e-4 Y; the key is the default 0.18.
  const ToneMapParameters flat = frame_tone_parameters(image_view(two_levels(2, 2, 0)));
  EXPECT_NEAR(flat.world_luminance, 2 * (1 + 1e-4), 1e-12);
  EXPECT_DOUBLE_EQ(flat.key, 0.18);
  // 5 of 50 pixels at 1000, the rest at 1: L_w = exp(0.9 ln(1 + d) + 0.1 ln(1000 + d)),
  // d = 0.1; the 1st and 99th percentiles are 1 and 1000.
  const ToneMapParameters p = frame_tone_parameters(image_view(two_levels(1, 1000, 5)));
  const double d = 0.1;
  const double lw = std::exp(0.9 * std::log(1 + d) + 0.1 * std::log(1000 + d));
  EXPECT_NEAR(p.world_luminance, lw, 1e-9 * lw);
  const double lo = std::log2(1 + d), hi = std::log2(1000 + d);
  EXPECT_NEAR(p.key, 0.18 * std::pow(4.0, (2 * std::log2(lw) - lo - hi) / (hi - lo)), 1e-12);
  EXPECT_LT(p.key, 0.18);  // a low-key picture (mostly dark): a smaller key
  EXPECT_NEAR(p.exposure(), p.key / lw, 1e-15);
  // A fixed key; invalid and NaN pixels do not count; an unseen map gives nothing.
  EnvMap masked = two_levels(1, 1000, 5);
  masked.valid.assign(50, 1);
  for (int i = 0; i < 5; ++i) masked.valid[size_t(i)] = 0;
  masked.pixel(7)[1] = NAN;
  const ToneMapParameters m = frame_tone_parameters(image_view(masked), 0.3);
  EXPECT_NEAR(m.world_luminance, 1 + 1e-4, 1e-12);
  EXPECT_DOUBLE_EQ(m.key, 0.3);
  masked.valid.assign(50, 0);
  EXPECT_EQ(frame_tone_parameters(image_view(masked)).world_luminance, 0);
}

TEST(TemporalToneMap, AStepIsFollowedExponentiallyInLogWithTheStatedTimeConstant) {
  TemporalToneMapOptions o;
  o.time_constant_s = 0.5;
  TemporalToneMapper mapper(o);
  const ToneMapParameters a = frame_tone_parameters(image_view(two_levels(1, 1, 0)));
  const ToneMapParameters b = frame_tone_parameters(image_view(two_levels(1, 1000, 5)));
  const double dt = 1 / 21.0;
  // The first frame sets the state; frames alike keep it.
  EXPECT_DOUBLE_EQ(mapper.update(a, NAN).exposure(), a.exposure());
  EXPECT_DOUBLE_EQ(mapper.update(a, dt).exposure(), a.exposure());
  const double step = std::log(b.exposure() / a.exposure());
  const double alpha = 1 - std::exp(-dt / o.time_constant_s);
  double previous = std::log(a.exposure());
  int settled = -1;
  for (int n = 1; n <= 80; ++n) {
    const ToneMapParameters& s = mapper.update(b, dt);
    // log L_w and log a each close the gap by exp(-n dt / tau), so log k does too.
    const double expect_lw = std::log(b.world_luminance) +
                             (std::log(a.world_luminance) - std::log(b.world_luminance)) * std::exp(-n * dt / 0.5);
    EXPECT_NEAR(std::log(s.world_luminance), expect_lw, 1e-9) << n;
    const double now = std::log(s.exposure());
    EXPECT_NEAR(now - std::log(a.exposure()), step * (1 - std::exp(-n * dt / 0.5)), 1e-9) << n;
    EXPECT_LE(std::abs(now - previous), alpha * std::abs(step) + 1e-12) << n;  // bounded per frame
    previous = now;
    if (settled < 0 && std::abs(now - std::log(b.exposure())) <= 0.01 * std::abs(step)) settled = n;
  }
  EXPECT_EQ(settled, int(std::ceil(std::log(100.0) * 0.5 * 21)));  // 4.61 tau: 49 frames
  // The same time in fewer, longer steps ends in the same state: time, not frames, counts.
  TemporalToneMapper sparse(o);
  sparse.update(a, NAN);
  for (int n = 0; n < 10; ++n) sparse.update(b, 3 * dt);
  TemporalToneMapper dense(o);
  dense.update(a, NAN);
  for (int n = 0; n < 30; ++n) dense.update(b, dt);
  EXPECT_NEAR(std::log(sparse.parameters().exposure()), std::log(dense.parameters().exposure()), 1e-12);
  // A black frame carries no information: the state stays. Time constant 0: per frame.
  const double kept = mapper.parameters().exposure();
  EXPECT_DOUBLE_EQ(mapper.update(frame_tone_parameters(image_view(two_levels(0, 0, 0))), dt).exposure(), kept);
  o.time_constant_s = 0;
  TemporalToneMapper instant(o);
  instant.update(a, dt);
  EXPECT_DOUBLE_EQ(instant.update(b, dt).exposure(), b.exposure());
}

TEST(TemporalToneMap, UnseenPixelsAreHatchedNotBlackAndAGivenExposureIsUsed) {
  EnvMap map = two_levels(1, 1, 0);
  map.valid.assign(50, 1);
  for (int i = 20; i < 50; ++i) map.valid[size_t(i)] = 0;
  map.pixel(3)[0] = INFINITY;
  ToneMapOptions o;
  o.unseen = UnseenStyle::Hatch;
  o.checker_px = 2;  // lines every 3 pixels, 1 wide
  o.exposure = 0.25;  // Y = 1 shows as 0.25 / 1.25
  const std::vector<float> out = tone_map(image_view(map), o);
  EXPECT_FLOAT_EQ(out[3 * 10 + 1], 0.2f);
  for (int i : {3, 20, 21, 22, 23, 49}) {
    const int u = i % 10, v = i / 10;
    const float expect = (u + v) % 3 == 0 ? 0.35f : 0.07f;
    for (int c = 0; c < 3; ++c) EXPECT_EQ(out[3 * size_t(i) + size_t(c)], expect) << i;
  }
}

}  // namespace
}  // namespace lp
