// core/healpix.h against chealpix itself (the peer these functions replace): the same
// pixel centres to the last bit and the same pixel for any direction, including the
// directions where the scheme's branches meet (poles, z = ±2/3, face edges, phi = 0 and
// 2 pi, lengths other than 1).
#include "core/healpix.h"

#include <chealpix.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numbers>
#include <random>
#include <vector>

namespace lp {
namespace {

bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

int64_t peer_pixel(int64_t nside, Vec3 d) {
  const double v[3] = {d.x, d.y, d.z};
  int64_t p = -1;
  vec2pix_nest64(nside, v, &p);
  return p;
}

TEST(Healpix, EveryPixelCentreOfSmallMapsIsChealpixsToTheLastBit) {
  for (int64_t nside = 1; nside <= 64; nside *= 2)
    for (int64_t p = 0; p < 12 * nside * nside; ++p) {
      double v[3];
      pix2vec_nest64(nside, p, v);
      const Vec3 d = healpix_direction(nside, p);
      ASSERT_TRUE(same_bits(d.x, v[0]) && same_bits(d.y, v[1]) && same_bits(d.z, v[2]))
          << "nside " << nside << " pixel " << p;
      ASSERT_EQ(healpix_pixel(nside, d), p) << "nside " << nside;  // and the centre maps back
    }
}

TEST(Healpix, RandomPixelsOfLargeMapsAreChealpixs) {
  std::mt19937_64 rng(7);
  for (int level = 7; level <= 29; ++level) {
    const int64_t nside = int64_t(1) << level;
    std::uniform_int_distribution<int64_t> pick(0, 12 * nside * nside - 1);
    for (int i = 0; i < 20000; ++i) {
      const int64_t p = pick(rng);
      double v[3];
      pix2vec_nest64(nside, p, v);
      const Vec3 d = healpix_direction(nside, p);
      ASSERT_TRUE(same_bits(d.x, v[0]) && same_bits(d.y, v[1]) && same_bits(d.z, v[2]))
          << "nside " << nside << " pixel " << p;
    }
  }
}

TEST(Healpix, AnyDirectionFallsInChealpixsPixel) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> gauss;
  std::uniform_real_distribution<double> scale(0.01, 100.0);
  std::vector<Vec3> directions;
  for (int i = 0; i < 200000; ++i) {
    const double s = scale(rng);
    directions.push_back({s * gauss(rng), s * gauss(rng), s * gauss(rng)});
  }
  // Where the branches meet: poles, axes, signed zeros, the belt's edges z = ±2/3, near-polar
  // directions (the sin-theta path), phi just below 0 and 2 pi.
  const double c = 2.0 / 3.0, s23 = std::sqrt(1 - c * c);
  for (const Vec3 d : {Vec3{0, 0, 1}, Vec3{0, 0, -1}, Vec3{1, 0, 0}, Vec3{-1, 0, 0}, Vec3{0, 1, 0}, Vec3{0, -1, 0},
                       Vec3{-0.0, -0.0, 1}, Vec3{1, -0.0, 0}, Vec3{-1, -0.0, 0}, Vec3{-1, 1e-300, 0},
                       Vec3{s23, 0, c}, Vec3{s23, 0, -c}, Vec3{0, s23, c}, Vec3{1e-9, 1e-9, 1}, Vec3{1e-9, -1e-12, -1},
                       Vec3{1, -1e-17, 0}, Vec3{1, 1, 1}, Vec3{-1, -1, -1}})
    directions.push_back(d);
  for (int i = 0; i < 2000; ++i) {  // on face edges of nside 8: the seams between pixels
    const double phi = 2 * std::numbers::pi * i / 2000, z = std::nextafter(c, i % 2 ? 1.0 : 0.0);
    directions.push_back({std::sqrt(1 - z * z) * std::cos(phi), std::sqrt(1 - z * z) * std::sin(phi), z});
  }
  for (int64_t nside : {int64_t(1), int64_t(2), int64_t(8), int64_t(256), int64_t(1) << 16, int64_t(1) << 29})
    for (const Vec3& d : directions)
      ASSERT_EQ(healpix_pixel(nside, d), peer_pixel(nside, d))
          << "nside " << nside << " direction " << d.x << " " << d.y << " " << d.z;
}

// Points inside a pixel: its centre at (0.5, 0.5), its corners on the boundaries of its
// neighbours, and any point back in the pixel.
TEST(Healpix, PointsInsideAPixelFallInIt) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.001, 0.999);
  for (int64_t nside : {int64_t(1), int64_t(4), int64_t(64), int64_t(1024)}) {
    std::uniform_int_distribution<int64_t> pick(0, 12 * nside * nside - 1);
    for (int i = 0; i < 20000; ++i) {
      const int64_t p = pick(rng);
      const Vec3 c = healpix_point(nside, p, 0.5, 0.5), centre = healpix_direction(nside, p);
      ASSERT_NEAR(c.x, centre.x, 1e-12) << p;
      ASSERT_NEAR(c.y, centre.y, 1e-12) << p;
      ASSERT_NEAR(c.z, centre.z, 1e-12) << p;
      ASSERT_EQ(healpix_pixel(nside, healpix_point(nside, p, u(rng), u(rng))), p) << "nside " << nside;
    }
  }
}

}  // namespace
}  // namespace lp

namespace lp {
namespace {

// q2tree bins a latlong or hemisphere map's pixels by healpix_pixel_at from each row's cos
// and sin theta and each column's phi: every pixel of the grids it bins (the shared maps'
// sizes, odd sizes, the default hemisphere) falls in the pixel of its direction vector, as
// healpix_pixel (chealpix's vec2pix_nest64, above) puts it.
TEST(Healpix, APixelFromAGridsAnglesIsThePixelOfItsDirection) {
  struct Grid {
    int w, h;
    double span;  // theta of the last row's far edge: pi (latlong) or pi / 2 (hemisphere)
    int nside;
  };
  for (const Grid g : {Grid{1024, 512, M_PI, 128}, Grid{2048, 1024, M_PI, 256}, Grid{256, 128, M_PI, 32},
                       Grid{202, 101, M_PI, 16}, Grid{360, 90, M_PI / 2, 64}, Grid{4096, 2048, M_PI, 512}}) {
    SCOPED_TRACE(testing::Message() << g.w << "x" << g.h << " nside " << g.nside);
    size_t differ = 0;
    for (int v = 0; v < g.h; ++v) {
      const double t = g.span * (v + 0.5) / g.h, st = std::sin(t), ct = std::cos(t);
      for (int u = 0; u < g.w; ++u) {
        const double p = 2 * M_PI * (u + 0.5) / g.w;
        const Vec3 d{st * std::cos(p), st * std::sin(p), ct};
        differ += healpix_pixel_at(g.nside, ct, st, p) != healpix_pixel(g.nside, d);
      }
    }
    EXPECT_EQ(differ, 0u);
  }
}

}  // namespace
}  // namespace lp
