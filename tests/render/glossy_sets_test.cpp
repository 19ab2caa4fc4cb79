// Glossy sets (Havran 2005, 4.2): H is a prefix of L with the same total power, the S_L
// lists hold every L light of the cone around any reflected direction, bad input throws.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/error.h"
#include "eval/synthetic_scene.h"
#include "render/glossy_sets.h"
#include "sampling/sampler.h"

namespace lp {
namespace {

std::vector<Light> scene_lights(int n) {
  static const EnvMap map = render_scene(describe_scene(), Layout::LatLong, 128, 64);
  return sample(map, n, Method::Pharr).lights;
}

TEST(GlossySets, HighIsAPrefixOfLowWithTheSamePower) {
  const auto low = scene_lights(512);
  const auto high = high_subset(low, 64);
  ASSERT_EQ(high.size(), 64u);
  const auto pl = total_power(low), ph = total_power(high);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(ph[size_t(c)], pl[size_t(c)], 1e-9 * pl[size_t(c)]);
  for (size_t i = 0; i < high.size(); ++i) {
    EXPECT_EQ(high[i].id, low[i].id);
    EXPECT_EQ(high[i].direction.x, low[i].direction.x);
    // Progressive equal-power lights: each H light carries |L| / |H| = 8 times an L light's
    // luminance (up to the per-channel power match of both lists).
    EXPECT_NEAR(high[i].luminance() / low[i].luminance(), 8.0, 0.08);
  }
  // The same as asking the sampler for 64 lights directly (progressive prefix).
  const auto direct = scene_lights(64);
  for (size_t i = 0; i < 64; ++i) EXPECT_NEAR(angle_between(direct[i].direction, high[i].direction), 0, 1e-9);
}

TEST(GlossySets, BadInputIsAClearError) {
  const auto low = scene_lights(64);
  AngularRegions cones({64, 16});
  EXPECT_THROW(high_subset(low, 0), InputError);
  EXPECT_THROW(high_subset(low, 65), InputError);
  EXPECT_THROW(make_glossy_sets({}, 1, cones), InputError);
  GlossyOptions o;
  o.cone_half_angle_deg = 0;
  EXPECT_THROW(make_glossy_sets(low, 8, cones, o), InputError);
  o.cone_half_angle_deg = 5;
  o.max_cone_lights = 0;
  EXPECT_THROW(make_glossy_sets(low, 8, cones, o), InputError);
}

TEST(GlossySets, ConeListsHoldEveryLowLightOfTheCone) {
  const auto low = scene_lights(2048);
  AngularRegions cones({256, 32});
  GlossyOptions o;
  o.cone_half_angle_deg = 6;
  const GlossySets sets = make_glossy_sets(low, 256, cones, o);
  std::mt19937 rng(9);
  std::normal_distribution<double> g;
  int inside = 0;
  for (int t = 0; t < 4000; ++t) {
    const Vec3 r = normalize({g(rng), g(rng), g(rng)});
    const int j = cones.region_of(r);
    const auto& L = sets.low_regions;
    std::vector<char> in(sets.low.size());
    for (uint32_t k = L.offsets[size_t(j)]; k < L.offsets[size_t(j) + 1]; ++k) in[L.indices[k]] = 1;
    for (size_t i = 0; i < sets.low.size(); ++i)
      if (angle_between(r, sets.low[i].direction) < sets.cone_half_angle) {
        ++inside;
        EXPECT_TRUE(in[i]) << "light " << i << " in the cone of r but not in S_L region " << j;
      }
  }
  EXPECT_GT(inside, 1000);  // the check saw many in-cone lights
}

}  // namespace
}  // namespace lp
