// The quadtree of seed 003: subdivision only where data already is, down to the minimum
// size; every update reaches all ancestors; look-ups take the nearest informed ancestor,
// per direction; the six bipyramid sectors and their centroid directions.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/accuracy.h"
#include "core/error.h"
#include "estimate/light_quadtree.h"

namespace lp {
namespace {

LightReading reading(double luminance) {
  LightReading r;
  r.luminance = luminance;
  r.colour = {1, 1, 1};
  r.cct_k = 6500;
  return r;
}

Vec3 dir_deg(double azimuth, double elevation) {
  const double a = azimuth * M_PI / 180, e = elevation * M_PI / 180;
  return {std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
}

TEST(Bipyramid, SectorsAre120DegreeWedgesPerHemisphere) {
  EXPECT_EQ(bipyramid_sector(dir_deg(0, 30)), 0);
  EXPECT_EQ(bipyramid_sector(dir_deg(59, 30)), 0);
  EXPECT_EQ(bipyramid_sector(dir_deg(-59, 30)), 0);
  EXPECT_EQ(bipyramid_sector(dir_deg(61, 30)), 1);
  EXPECT_EQ(bipyramid_sector(dir_deg(120, 80)), 1);
  EXPECT_EQ(bipyramid_sector(dir_deg(179, 10)), 1);
  EXPECT_EQ(bipyramid_sector(dir_deg(181, 10)), 2);
  EXPECT_EQ(bipyramid_sector(dir_deg(240, 10)), 2);
  EXPECT_EQ(bipyramid_sector(dir_deg(0, -30)), 3);
  EXPECT_EQ(bipyramid_sector(dir_deg(120, -5)), 4);
  EXPECT_EQ(bipyramid_sector(dir_deg(240, -89)), 5);
}

// The light of a sector points at the mean of the unit vectors of the sector: checked by
// brute force over uniformly random directions.
TEST(Bipyramid, DirectionsAreSectorCentroids) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g;
  std::array<Vec3, kBipyramidSectors> sum{};
  std::array<int, kBipyramidSectors> count{};
  for (int i = 0; i < 1000000; ++i) {
    const Vec3 d = normalize(Vec3{g(rng), g(rng), g(rng)});
    const int s = bipyramid_sector(d);
    sum[s] = sum[s] + d;
    ++count[s];
  }
  for (int s = 0; s < kBipyramidSectors; ++s) {
    EXPECT_NEAR(count[s] / 1e6, 1.0 / 6, 0.002) << s;  // equal solid angles
    const Vec3 c = bipyramid_direction(s);
    EXPECT_NEAR(length(c), 1.0, 1e-12);
    EXPECT_LT(angle_between(normalize(sum[s]), c) * 180 / M_PI, 0.3) << s;  // Monte Carlo noise ~0.1 deg
    EXPECT_NEAR(std::asin(std::fabs(c.z)) * 180 / M_PI, 37.59, 0.01);
  }
}

TEST(LightQuadtree, SubdividesOnlyWhereDataAlreadyIsDownToMinSize) {
  QuadtreeOptions o;
  o.root_size = 8;
  o.min_size = 1;
  LightQuadtree t(o);  // root [-4, 4]^2
  const Vec3 up = dir_deg(0, 30);
  // First frame: stored in the empty root, no split.
  EXPECT_EQ(t.update(0.5, 0.5, up, reading(100), 0), 0);
  EXPECT_EQ(t.nodes().size(), 1u);
  // Second frame in the same (informed) cell: split into four of side 4.
  const int a = t.update(0.5, 0.5, up, reading(100), 1);
  EXPECT_EQ(t.nodes().size(), 5u);
  EXPECT_EQ(t.nodes()[a].size, 4.0);
  EXPECT_EQ(t.nodes()[a].depth, 1);
  EXPECT_TRUE(t.nodes()[a].contains(0.5, 0.5));
  // A frame in an empty sibling cell: stored there, no split.
  const int b = t.update(-2.0, -2.0, up, reading(50), 2);
  EXPECT_EQ(t.nodes().size(), 5u);
  EXPECT_EQ(t.nodes()[b].depth, 1);
  EXPECT_NE(a, b);
  // Staying at one spot: 4 -> 2 -> 1, then never below min_size.
  for (int i = 0; i < 20; ++i) t.update(0.5, 0.5, up, reading(100), 3 + i);
  EXPECT_EQ(t.max_depth(), 3);
  for (const QuadNode& n : t.nodes()) EXPECT_GE(n.size, o.min_size);
  const int leaf = t.leaf_at(0.5, 0.5);
  EXPECT_EQ(t.nodes()[leaf].size, 1.0);
  EXPECT_EQ(t.nodes().size(), 13u);  // root + 3 splits of 4
  // Children tile their parent exactly.
  for (const QuadNode& n : t.nodes()) {
    if (n.leaf()) continue;
    for (int c : n.children) {
      EXPECT_EQ(t.nodes()[c].size, n.size / 2);
      EXPECT_EQ(std::fabs(t.nodes()[c].cx - n.cx), n.size / 4);
      EXPECT_EQ(std::fabs(t.nodes()[c].cy - n.cy), n.size / 4);
    }
  }
}

TEST(LightQuadtree, UpdatesReachEveryAncestor) {
  QuadtreeOptions o;
  o.root_size = 16;
  o.min_size = 1;
  LightQuadtree t(o);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> pos(-7.9, 7.9), lum(10, 1000);
  std::vector<std::tuple<double, double, int, double>> frames;
  for (int i = 0; i < 400; ++i) {
    const double x = pos(rng), y = pos(rng), l = lum(rng);
    const Vec3 v = dir_deg(360 * (i % 7) / 7.0, i % 2 ? 20 : -20);
    t.update(x, y, v, reading(l), i);
    frames.emplace_back(x, y, bipyramid_sector(v), l);
  }
  // Brute force: a node's sector weight = frames that were stored in it or below it, and its
  // mean = their mean, i.e. every frame whose position lies in the node and that arrived
  // after the node was created (all of them, for the root).
  const QuadNode& root = t.nodes()[0];
  for (int s = 0; s < kBipyramidSectors; ++s) {
    double n = 0, sum = 0;
    for (const auto& [x, y, fs, l] : frames)
      if (fs == s) n += 1, sum += l;
    EXPECT_EQ(root.sectors[s].weight, n);
    EXPECT_NEAR(root.sectors[s].luminance, sum / n, 1e-9 * sum / n);
    EXPECT_NEAR(root.sectors[s].radiance[1] * 683.0, sum / n, 1e-9 * sum / n);
  }
  // Parent weight = own stores + children's weights, for every node and sector.
  std::vector<std::array<double, kBipyramidSectors>> child_sum(t.nodes().size());
  for (size_t i = 1; i < t.nodes().size(); ++i)
    for (int s = 0; s < kBipyramidSectors; ++s) child_sum[t.nodes()[i].parent][s] += t.nodes()[i].sectors[s].weight;
  for (size_t i = 0; i < t.nodes().size(); ++i)
    for (int s = 0; s < kBipyramidSectors; ++s) EXPECT_GE(t.nodes()[i].sectors[s].weight, child_sum[i][s]);
  EXPECT_GT(t.max_depth(), 2);
}

TEST(LightQuadtree, LookupTakesNearestInformedAncestorPerSector) {
  QuadtreeOptions o;
  o.root_size = 8;
  o.min_size = 1;
  LightQuadtree t(o);
  const Vec3 up0 = dir_deg(0, 30), up1 = dir_deg(120, 30);
  t.update(1, 1, up0, reading(100), 0);  // root
  t.update(1, 1, up0, reading(300), 1);  // split: child (+,+) gets 300
  t.update(-1, 1, up1, reading(40), 2);  // child (-,+) gets sector 1
  const int child = t.leaf_at(1, 1);
  auto look = t.lookup(1, 1);
  EXPECT_EQ(look[0].node, child);
  EXPECT_NEAR(look[0].sample.luminance, 300, 1e-9);
  // Sector 1 was never seen in this cell: its nearest informed ancestor is the root.
  EXPECT_EQ(look[1].node, 0);
  EXPECT_NEAR(look[1].sample.luminance, 40, 1e-9);
  // An empty cell (-,-): everything from the root (sector 0 the mean of 100 and 300).
  look = t.lookup(-2, -2);
  EXPECT_EQ(look[0].node, 0);
  EXPECT_NEAR(look[0].sample.luminance, 200, 1e-9);
  // min_weight 2: the child's single frame is not enough, the root (2 frames) answers.
  EXPECT_EQ(t.lookup(1, 1, -1, 2)[0].node, 0);
  // Shrinkage: root mean 200 (weight 2) pulled towards the child's 300 by 1 / (1 + k).
  EXPECT_NEAR(t.lookup_shrunk(1, 1, 1.0)[0].sample.luminance, 250, 1e-9);
  EXPECT_NEAR(t.lookup_shrunk(1, 1, 3.0)[0].sample.luminance, 225, 1e-9);
  EXPECT_NEAR(t.lookup_shrunk(-2, -2, 3.0)[0].sample.luminance, 200, 1e-9);
  // max_depth 0: the single global estimate.
  EXPECT_EQ(t.lookup(1, 1, 0)[0].node, 0);
  // Never-observed sectors: filled from the same hemisphere (up) and from all (down).
  EXPECT_TRUE(look[2].filled);
  EXPECT_NEAR(look[2].sample.luminance, (200 + 40) / 2.0, 1e-9);
  EXPECT_TRUE(look[4].filled);
  // Outside the root: not stored, look-ups use the root.
  EXPECT_EQ(t.update(10, 0, up0, reading(1), 3), -1);
  EXPECT_EQ(t.outside_updates(), 1);
  EXPECT_EQ(t.lookup(10, 0)[0].node, 0);
}

TEST(LightQuadtree, LightsCarryTheSectorPowerAndRoundTripThroughJson) {
  QuadtreeOptions o;
  o.origin_x = 2;
  o.origin_y = -1;
  LightQuadtree t(o);
  // A uniform field of luminance L seen in every sector: total power 4 pi L / 683, and the
  // irradiance of the six lights on any normal is within the bipyramid's error of pi L.
  const double L = 683.0;
  for (int s = 0; s < 6; ++s) t.update(2, -1, bipyramid_direction(s), reading(L), s);
  const LightList lights = t.lights_at(2, -1);
  ASSERT_EQ(lights.lights.size(), 6u);
  EXPECT_EQ(lights.units, Units::Radiance);
  const auto power = total_power(lights.lights);
  EXPECT_NEAR(power[1], 4 * M_PI, 1e-9);
  for (const Vec3 n : fibonacci_sphere(64)) {
    const double e = lights_irradiance(lights.lights, n);
    EXPECT_NEAR(e / M_PI, 1.0, 0.35);  // six lights are a coarse cosine: up to ~30 % off
  }
  const LightQuadtree back = LightQuadtree::from_json(t.to_json(), "model.json");
  const LightList again = back.lights_at(2, -1);
  ASSERT_EQ(again.lights.size(), 6u);
  for (size_t i = 0; i < 6; ++i) {
    EXPECT_EQ(again.lights[i].id, lights.lights[i].id);
    EXPECT_NEAR(again.lights[i].rgb[0], lights.lights[i].rgb[0], 1e-12);
  }
  EXPECT_EQ(back.nodes().size(), t.nodes().size());
  EXPECT_THROW(LightQuadtree::from_json("{\"format\": \"other\"}", "m.json"), InputError);
  EXPECT_THROW(LightQuadtree::from_json("not json", "m.json"), InputError);
}

TEST(LightQuadtree, BadOptionsAreInputErrors) {
  QuadtreeOptions o;
  o.min_size = 0;
  EXPECT_THROW(LightQuadtree{o}, InputError);
  o.min_size = 64;
  EXPECT_THROW(LightQuadtree{o}, InputError);
  LightQuadtree t(QuadtreeOptions{});
  EXPECT_THROW(t.update(0, 0, {0, 0, 0}, reading(1), 0), InputError);
}

}  // namespace
}  // namespace lp
