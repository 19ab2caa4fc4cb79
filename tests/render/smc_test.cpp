// SMC across frames: unbiased on static maps (its Z is BIS's at frame 0 and the reweighting
// ratio is exactly 1), ESS-triggered resampling and the reset on an abrupt switch, and the
// map-power reset that catches a light switched on where no particle was.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "core/envmap.h"
#include "core/error.h"
#include "eval/synthetic_scene.h"
#include "eval/synthetic_sequence.h"
#include "render/smc.h"

namespace lp {
namespace {

double lum(const Rgb& c) { return luminance(c.data()); }

std::shared_ptr<const EnvDistribution> dist(const EnvMap& m) { return std::make_shared<const EnvDistribution>(m); }

TEST(Smc, UnbiasedOnStaticConstantAndSunMaps) {
  EnvMap constant = make_latlong(64, 32);
  std::fill(constant.rgb.begin(), constant.rgb.end(), 2.0f);
  EnvMap sun = make_latlong(64, 32);
  const size_t sun_pixel = 9 * 64 + 10;
  sun.pixel(sun_pixel)[0] = sun.pixel(sun_pixel)[1] = sun.pixel(sun_pixel)[2] = 500.0f;
  const Vec3 s = pixel_direction(sun, sun_pixel);
  const Vec3 n = normalize(s + Vec3{0, 0, 1});
  struct Case {
    const EnvMap* map;
    Brdf brdf;
    double truth;
  };
  const double e = 10;
  const ShadingPoint lam{n, n, Brdf{LobeType::Lambertian, {0.5, 0.5, 0.5}, 0}, {}};
  const ShadingPoint gl{n, n, Brdf{LobeType::BlinnPhong, {1, 1, 1}, e}, {}};
  const std::vector<std::pair<const EnvMap*, ShadingPoint>> cases{{&constant, lam}, {&constant, gl}, {&sun, lam}};
  for (const auto& [map, point] : cases) {
    const auto d = dist(*map);
    const double truth = lum(reference_reflected(*map, point, {16}));
    SmcOptions o;
    o.particles = 4;
    o.init_proposal_map_share = 0.5;  // the sun is a point for the lobe: let BIS find it
    const int seeds = 2000;
    double sum = 0, sum2 = 0;
    for (int k = 0; k < seeds; ++k) {
      SmcEstimator smc(point, o, uint64_t(k));
      double v = 0;
      for (int f = 0; f < 4; ++f) v = lum(smc.step(d));  // the same map 4 times: Z never changes
      sum += v;
      sum2 += v * v;
    }
    const double mean = sum / seeds, se = std::sqrt((sum2 / seeds - mean * mean) / seeds);
    EXPECT_NEAR(mean, truth, 4 * se + 2e-3 * truth);
    EXPECT_LT(4 * se, 0.1 * truth);
  }
}

// Abrupt switch: a strong light (3x the base's power) facing the normal goes off at the
// step frame. Particles sitting on it lose all weight: the ESS falls below 2N/3.
struct Switch {
  EnvMap base;
  SequenceOptions so;
  ShadingPoint point;
};
Switch make_switch() {
  Switch s;
  s.base = render_scene(describe_scene(), Layout::LatLong, 64, 32);
  s.so.scenario = Scenario::AbruptSwitch;
  s.so.frames = 8;
  s.so.light_power_share = 3.0;
  s.so.light_radius_deg = 5.0;
  const Vec3 light = *added_light_direction(s.so, 0);
  s.point = ShadingPoint{light, light, Brdf{LobeType::Lambertian, {0.8, 0.8, 0.8}, 0}, {}};
  return s;
}

TEST(Smc, AbruptSwitchTriggersEssResamplingAndAZRatioReset) {
  const Switch sw = make_switch();
  const int step = step_frame(sw.so);
  SmcOptions o;
  o.particles = 32;
  o.init_proposal_map_share = 0.5;
  o.map_power_reset_ratio = 0;  // only the paper's Z-ratio reset
  SmcEstimator smc(sw.point, o, 17);
  for (int f = 0; f < sw.so.frames; ++f) {
    const EnvMap frame = render_sequence_frame(sw.base, sw.so, f);
    const int resamples_before = smc.stats().resamples;
    const double truth = lum(reference_reflected(frame, sw.point));
    const double est = lum(smc.step(dist(frame)));
    if (f == step) {
      EXPECT_LT(smc.stats().last_ess, 2.0 / 3.0 * o.particles);
      EXPECT_EQ(smc.stats().resamples, resamples_before + 1);
      EXPECT_TRUE(smc.stats().last_reset) << "Z fell by ~4x: the ratio test must re-initialise";
    } else if (f > 0) {
      EXPECT_FALSE(smc.stats().last_reset) << "frame " << f;
    }
    EXPECT_NEAR(est, truth, 0.35 * truth) << "frame " << f;
  }
  EXPECT_EQ(smc.stats().resets, 1);
}

TEST(Smc, WithoutResetsTheEssResamplingAloneKeepsTheEstimateAfterTheLightGoesOff) {
  const Switch sw = make_switch();
  const int step = step_frame(sw.so);
  SmcOptions o;
  o.particles = 128;  // after the switch only ~1/4 of them carry the estimate
  o.init_proposal_map_share = 0.5;
  o.reset_ratio = 0;
  o.map_power_reset_ratio = 0;
  SmcEstimator smc(sw.point, o, 23);
  for (int f = 0; f < sw.so.frames; ++f) {
    const EnvMap frame = render_sequence_frame(sw.base, sw.so, f);
    const double truth = lum(reference_reflected(frame, sw.point));
    const double est = lum(smc.step(dist(frame)));
    if (f == step) {
      EXPECT_TRUE(smc.stats().last_resampled);
    }
    if (f >= step) {
      EXPECT_NEAR(est, truth, 0.35 * truth) << "frame " << f;
    }
  }
  EXPECT_EQ(smc.stats().resets, 0);
}

TEST(Smc, ALightSwitchedOnIsCaughtOnlyByTheMapPowerReset) {
  // The switch played backwards: the light comes on where no particle sits. No weight
  // changes, so Z cannot see it; the map's power can.
  const Switch sw = make_switch();
  const int step = step_frame(sw.so);
  std::vector<EnvMap> frames;
  for (int f = sw.so.frames - 1; f >= 0; --f) frames.push_back(render_sequence_frame(sw.base, sw.so, f));
  const int on = sw.so.frames - step;  // first frame with the light on
  for (bool power_reset : {false, true}) {
    SmcOptions o;
    o.particles = 32;
    o.init_proposal_map_share = 0.5;
    o.map_power_reset_ratio = power_reset ? 1.1 : 0;
    o.local_move_probability = 1.0;  // local moves only: the particles cannot jump to the light
    SmcEstimator smc(sw.point, o, 5);
    double est = 0, truth = 0;
    for (int f = 0; f <= on; ++f) {
      truth = lum(reference_reflected(frames[size_t(f)], sw.point));
      est = lum(smc.step(dist(frames[size_t(f)])));
    }
    if (power_reset) {
      EXPECT_TRUE(smc.stats().last_reset);
      EXPECT_NEAR(est, truth, 0.35 * truth);
    } else {
      EXPECT_LT(est, 0.5 * truth) << "without the map-power reset SMC misses the new light";
    }
  }
}

TEST(Smc, ResetEveryReinitialisesOnSchedule) {
  EnvMap constant = make_latlong(32, 16);
  std::fill(constant.rgb.begin(), constant.rgb.end(), 1.0f);
  const auto d = dist(constant);
  SmcOptions o;
  o.reset_every = 3;
  SmcEstimator smc(ShadingPoint{{0, 0, 1}, {0, 0, 1}, Brdf{}, {}}, o, 9);
  for (int f = 0; f < 10; ++f) {
    smc.step(d);
    EXPECT_EQ(smc.stats().last_reset, f > 0 && f % 3 == 0) << "frame " << f;
  }
  EXPECT_EQ(smc.stats().resets, 3);
}

TEST(Smc, RefusesBadOptions) {
  const ShadingPoint p{{0, 0, 1}, {0, 0, 1}, Brdf{}, {}};
  SmcOptions o;
  o.particles = 0;
  EXPECT_THROW(SmcEstimator(p, o, 1), InputError);
  o = {};
  o.ess_fraction = 1.5;
  EXPECT_THROW(SmcEstimator(p, o, 1), InputError);
  o = {};
  o.local_move_deg = 0;
  EXPECT_THROW(SmcEstimator(p, o, 1), InputError);
  o = {};
  o.reset_every = -1;
  EXPECT_THROW(SmcEstimator(p, o, 1), InputError);
  ShadingPoint bad = p;
  bad.brdf = Brdf{LobeType::BlinnPhong, {1, 1, 1}, 0};
  EXPECT_THROW(SmcEstimator(bad, SmcOptions{}, 1), InputError);
}

}  // namespace
}  // namespace lp
