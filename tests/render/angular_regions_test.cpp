// Angular regions (Havran 2005, 4.1): the LUT addresses the cube map as documented, the
// measured radius bounds every direction of a region, culling never drops a light that
// lights some normal of the region (exhaustive over a fine grid covering each region's
// closure), and the lists keep the lights' progressive order.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "core/error.h"
#include "render/angular_regions.h"

namespace lp {
namespace {

Vec3 random_unit(std::mt19937& rng) {
  std::normal_distribution<double> g;
  for (;;) {
    Vec3 v{g(rng), g(rng), g(rng)};
    if (length(v) > 1e-9) return normalize(v);
  }
}

std::vector<Light> random_lights(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<Light> lights(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    lights[size_t(i)].id = uint64_t(i) + 1;
    lights[size_t(i)].direction = random_unit(rng);
    lights[size_t(i)].rgb = {1, 1, 1};
  }
  return lights;
}

// Number of (normal, light) pairs where the light lights the normal (n.d > 0) but is
// missing from the list of the normal's region. Normals: a (g+1) x (g+1) grid over every
// LUT texel including its edges and corners, attributed to the texel's region - the
// closure of each region, so boundary normals are tested against every region they touch.
int missed_pairs(const AngularRegions& regions, const RegionLights& lists, const std::vector<Light>& lights, int g) {
  const int texels = 6 * regions.face_size() * regions.face_size();
  std::vector<char> in(lights.size());
  int missed = 0;
  for (int t = 0; t < texels; ++t) {
    const int j = regions.lut()[size_t(t)];
    std::fill(in.begin(), in.end(), 0);
    for (uint32_t k = lists.offsets[size_t(j)]; k < lists.offsets[size_t(j) + 1]; ++k) in[lists.indices[k]] = 1;
    for (int a = 0; a <= g; ++a)
      for (int b = 0; b <= g; ++b) {
        const Vec3 n = cube_texel_direction(t, regions.face_size(), double(a) / g, double(b) / g);
        for (size_t i = 0; i < lights.size(); ++i)
          if (!in[i] && dot(n, lights[i].direction) > 0) ++missed;
      }
  }
  return missed;
}

TEST(AngularRegions, BadInputIsAClearError) {
  EXPECT_THROW(AngularRegions({0, 16}), InputError);
  EXPECT_THROW(AngularRegions({-3, 16}), InputError);
  EXPECT_THROW(AngularRegions({64, 0}), InputError);
  try {
    AngularRegions r({0, 16});
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("regions"), std::string::npos) << e.what();
  }
  AngularRegions r({16, 8});
  std::vector<Light> none;
  EXPECT_THROW(assign_lights(r, none, -0.1), InputError);
}

TEST(AngularRegions, CubeTexelAddressingRoundTripsAndFollowsOpenGL) {
  const int n = 8;
  for (int i = 0; i < 6 * n * n; ++i) EXPECT_EQ(cube_texel_of(cube_texel_direction(i, n), n), i);
  // OpenGL: +X face, sc = -z, tc = -y; so (1, -0.9, -0.9) is near (s, t) = (max, max).
  EXPECT_EQ(cube_texel_of(normalize({1, -0.9, -0.9}), n), (0 * n + n - 1) * n + n - 1);
  // -Z face (5): sc = -x, tc = -y; (0.9, 0.9, -1) is at s = 0, t = 0.
  EXPECT_EQ(cube_texel_of(normalize({0.9, 0.9, -1}), n), 5 * n * n);
  // +Y face (2): sc = x, tc = z.
  EXPECT_EQ(cube_texel_of(normalize({-0.9, 1, 0.9}), n), (2 * n + n - 1) * n + 0);
}

TEST(AngularRegions, MeasuredRadiusBoundsEveryDirectionOfItsRegion) {
  AngularRegions regions({200, 32});
  EXPECT_EQ(regions.count(), 200);
  std::mt19937 rng(3);
  double worst = -1;
  for (int i = 0; i < 100000; ++i) {
    const Vec3 d = random_unit(rng);
    const int j = regions.region_of(d);
    const double a = angle_between(d, regions.centres()[size_t(j)]);
    EXPECT_LE(a, regions.radius()[size_t(j)] + 1e-12);
    worst = std::max(worst, a - regions.radius()[size_t(j)]);
  }
  // The radius is tight: some direction comes within half a texel of it, and a cell of 200
  // on the sphere has radius above the equal-area disc's acos(1 - 2/200) = 8.1 deg.
  EXPECT_GT(worst, -0.03);
  EXPECT_GT(regions.max_radius(), std::acos(1 - 2.0 / 200));
  EXPECT_LT(regions.max_radius(), 3 * std::acos(1 - 2.0 / 200));
}

TEST(AngularRegions, CullingNeverDropsAContributingLight) {
  AngularRegions regions({48, 12});
  const auto lights = random_lights(600, 11);
  const RegionLights lists = assign_lights(regions, lights);
  EXPECT_EQ(missed_pairs(regions, lists, lights, 6), 0);
  // Something is culled: on average (1 + sin alpha) / 2 of the lights remain, well below all.
  const double kept = double(lists.indices.size()) / (regions.count() * double(lights.size()));
  EXPECT_LT(kept, 0.5 * (1 + std::sin(regions.max_radius())) + 0.03);
  EXPECT_GT(kept, 0.5);
}

TEST(AngularRegions, HalfTheRadiusDropsLightsSoTheTestCanFail) {
  // The paper's beta = alpha/2 + pi/2 read with alpha = our radius: too tight.
  AngularRegions regions({48, 12});
  const auto lights = random_lights(600, 11);
  const RegionLights tight = assign_lights(regions, lights, M_PI / 2 - regions.max_radius() / 2);
  EXPECT_GT(missed_pairs(regions, tight, lights, 6), 0);
}

TEST(AngularRegions, ListsKeepTheProgressiveOrderAndHoldExactlyTheReachableLights) {
  AngularRegions regions({100, 16});
  const auto lights = random_lights(1000, 5);
  const RegionLights lists = assign_lights(regions, lights);
  ASSERT_EQ(lists.offsets.size(), size_t(regions.count()) + 1);
  for (int j = 0; j < regions.count(); ++j) {
    const uint32_t b = lists.offsets[size_t(j)], e = lists.offsets[size_t(j) + 1];
    for (uint32_t k = b + 1; k < e; ++k) EXPECT_LT(lists.indices[k - 1], lists.indices[k]);
    // Brute force: exactly the lights within radius + 90 deg of the centre.
    size_t expected = 0;
    for (const Light& l : lights)
      expected += angle_between(regions.centres()[size_t(j)], l.direction) <= regions.radius()[size_t(j)] + M_PI / 2;
    EXPECT_EQ(lists.size(j), expected) << "region " << j;
  }
}

TEST(AngularRegions, OneRegionKeepsEverything) {
  AngularRegions regions({1, 4});
  EXPECT_NEAR(regions.max_radius(), M_PI, 1e-9);
  const auto lights = random_lights(50, 2);
  EXPECT_EQ(assign_lights(regions, lights).indices.size(), 50u);
}

}  // namespace
}  // namespace lp
