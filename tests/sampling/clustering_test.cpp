// Light clustering (Havran 2005, section 4.3): at most Q lights, exact power, stable ids,
// and the same clusters as a brute-force O(n^2) reading of the paper's algorithm.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>

#include "core/error.h"
#include "sampling/clustering.h"

namespace lp {
namespace {

std::vector<Light> random_lights(std::mt19937& rng, int n, bool upper_only = false) {
  std::uniform_real_distribution<double> u(0, 1);
  std::vector<Light> lights(n);
  for (int i = 0; i < n; ++i) {
    const double z = upper_only ? u(rng) : 1 - 2 * u(rng);
    lights[i].id = 1000 + 3 * i;
    lights[i].direction = direction_from_angles(std::acos(z), 2 * M_PI * u(rng));
    lights[i].rgb = {u(rng), 10 * u(rng), 0.01 * u(rng)};
    lights[i].solid_angle = 4 * M_PI / n;
  }
  return lights;
}

// The paper's algorithm, literally: every unassigned light in input order takes every
// unassigned light within eps (checked by angle, against all n); eps grows by 10 % until
// there are at most Q clusters.
std::vector<Light> brute_force(const std::vector<Light>& lights, int q, double eps) {
  for (;;) {
    std::vector<int> cluster(lights.size(), -1);
    std::vector<Light> out;
    std::vector<Vec3> sum;
    for (size_t i = 0; i < lights.size(); ++i) {
      if (cluster[i] >= 0) continue;
      const int c = static_cast<int>(out.size());
      out.push_back(Light{});
      out.back().id = lights[i].id;
      sum.push_back(Vec3{});
      for (size_t j = i; j < lights.size(); ++j)
        if (cluster[j] < 0 && (j == i || angle_between(lights[i].direction, lights[j].direction) <= eps)) cluster[j] = c;
    }
    if (static_cast<int>(out.size()) > q) {
      eps *= 1.1;
      continue;
    }
    for (size_t i = 0; i < lights.size(); ++i) {
      Light& o = out[cluster[i]];
      sum[cluster[i]] = sum[cluster[i]] + lights[i].direction;
      for (int k = 0; k < 3; ++k) o.rgb[k] += lights[i].rgb[k];
      o.solid_angle += lights[i].solid_angle;
    }
    for (size_t c = 0; c < out.size(); ++c) out[c].direction = normalize(sum[c]);
    return out;
  }
}

TEST(ClusterRadius, IsTheHemisphereFormulaOfThePaperOrItsFullSphereAnalogue) {
  EXPECT_NEAR(cluster_radius(200, {.correction = 1.85, .upper_hemisphere_only = true}),
              1.85 * std::asin(std::sqrt(2.0 / 200)), 1e-15);
  EXPECT_NEAR(cluster_radius(200), 1.85 * std::asin(std::sqrt(4.0 / 200)), 1e-15);
  // Q = 8 on the sphere: sin(eps / c_f) = 1/sqrt(2) -> eps = 1.85 * 45 degrees.
  EXPECT_NEAR(cluster_radius(8), 1.85 * M_PI / 4, 1e-15);
  EXPECT_NEAR(cluster_radius(2), 1.85 * M_PI / 2, 1e-15);  // clamped asin(1)
  EXPECT_THROW(cluster_radius(0), InputError);
  EXPECT_THROW(cluster_lights({}, -3), InputError);
  EXPECT_TRUE(cluster_lights({}, 5).empty());
}

TEST(Clustering, NeverReturnsMoreThanQLightsAndPreservesPowerPerChannel) {
  std::mt19937 rng(11);
  for (int n : {300, 700, 2000}) {
    for (int q : {8, 20, 50, 120, 200}) {
      for (bool upper : {false, true}) {
        const std::vector<Light> lights = random_lights(rng, n, upper);
        const std::vector<Light> out = cluster_lights(lights, q, {.correction = 1.85, .upper_hemisphere_only = upper});
        EXPECT_LE(static_cast<int>(out.size()), q) << n << " lights, Q " << q;
        EXPECT_GE(out.size(), 1u);
        const auto before = total_power(lights), after = total_power(out);
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(after[c], before[c], 1e-12 * before[c]);
        double omega = 0;
        for (const Light& l : out) omega += l.solid_angle;
        EXPECT_NEAR(omega, 4 * M_PI, 1e-12);
        // Ids are input ids, unique, in input order; directions are unit vectors.
        size_t last = 0;
        for (const Light& l : out) {
          const size_t index = (l.id - 1000) / 3;
          ASSERT_LT(index, lights.size());
          EXPECT_EQ(lights[index].id, l.id);
          if (&l != &out.front()) { EXPECT_GT(index, last); }
          last = index;
          EXPECT_NEAR(length(l.direction), 1.0, 1e-14);
        }
      }
    }
  }
}

TEST(Clustering, MatchesTheBruteForceReadingOfThePaper) {
  std::mt19937 rng(21);
  for (int n : {50, 300, 1000}) {
    for (int q : {1, 3, 8, 40, 200, 2000}) {
      const std::vector<Light> lights = random_lights(rng, n);
      const std::vector<Light> fast = cluster_lights(lights, q);
      const std::vector<Light> slow = brute_force(lights, q, cluster_radius(q));
      ASSERT_EQ(fast.size(), slow.size()) << n << " lights, Q " << q;
      for (size_t c = 0; c < fast.size(); ++c) {
        EXPECT_EQ(fast[c].id, slow[c].id);
        EXPECT_LT(angle_between(fast[c].direction, slow[c].direction), 1e-12);
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(fast[c].rgb[k], slow[c].rgb[k], 1e-12 * slow[c].rgb[k]);
      }
    }
  }
}

TEST(Clustering, TwoTightGroupsFarApartGiveExactlyTwoClustersAtTheirMeanDirections) {
  std::mt19937 rng(4);
  std::normal_distribution<double> jitter(0, 0.01);
  const Vec3 centre[2] = {normalize(Vec3{0.2, 0.1, 1}), normalize(Vec3{1, -0.5, -0.3})};
  std::vector<Light> lights;
  Vec3 sum[2];
  std::array<double, 3> power[2] = {{0, 0, 0}, {0, 0, 0}};
  for (int i = 0; i < 60; ++i) {
    const int g = (i % 3 == 0) ? 1 : 0;  // interleaved; the first light is in group 1
    Light l;
    l.id = 500 + i;
    l.direction = normalize(centre[g] + Vec3{jitter(rng), jitter(rng), jitter(rng)});
    l.rgb = {1.0 + i, 2.0, 0.5 * g};
    sum[g] = sum[g] + l.direction;
    for (int c = 0; c < 3; ++c) power[g][c] += l.rgb[c];
    lights.push_back(l);
  }
  const std::vector<Light> out = cluster_lights(lights, 50);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(out[0].id, 500u);  // light 0 is in group 1 and comes first
  EXPECT_EQ(out[1].id, 501u);
  EXPECT_LT(angle_between(out[0].direction, normalize(sum[1])), 1e-14);
  EXPECT_LT(angle_between(out[1].direction, normalize(sum[0])), 1e-14);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(out[0].rgb[c], power[1][c], 1e-12);
    EXPECT_NEAR(out[1].rgb[c], power[0][c], 1e-12);
  }
}

TEST(Clustering, LightsFartherApartThanEpsStaySeparate) {
  // Six lights on the axes are 90 degrees apart; Q = 200 on the sphere gives eps = 15 degrees.
  std::vector<Light> lights;
  const Vec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int i = 0; i < 6; ++i) {
    Light l;
    l.id = i + 1;
    l.direction = axes[i];
    l.rgb = {1, 1, 1};
    lights.push_back(l);
  }
  EXPECT_EQ(cluster_lights(lights, 200).size(), 6u);
  // Q = 1 puts all of them into the first light's cluster.
  const std::vector<Light> one = cluster_lights(lights, 1);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].id, 1u);
  EXPECT_EQ(one[0].rgb[0], 6.0);
  EXPECT_EQ(one[0].direction.x, 1.0);  // the mean is zero: the seed's direction is kept
}

}  // namespace
}  // namespace lp
