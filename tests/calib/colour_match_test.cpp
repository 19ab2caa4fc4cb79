#include "calib/colour_match.h"

#include <gtest/gtest.h>

#include <fstream>
#include <random>

#include "core/error.h"

namespace lp {
namespace {

TEST(ColourMatch, RecoversAKnownMatrixFromNoiselessPatches) {
  const Mat3 truth{{0.9, 0.08, 0.02, 0.05, 1.1, -0.03, 0.01, 0.12, 0.85}};
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0.05, 1.0);
  std::vector<ColourPatchPair> pairs;
  for (int i = 0; i < 24; ++i) {  // a 24-patch chart
    ColourPatchPair p;
    p.probe = {u(rng), u(rng), u(rng)};
    const Vec3 q = truth * Vec3{p.probe[0], p.probe[1], p.probe[2]};
    p.plate = {q.x, q.y, q.z};
    pairs.push_back(p);
  }
  const ColourMatch m = fit_colour_match(pairs);
  for (size_t i = 0; i < 9; ++i) EXPECT_NEAR(m.matrix.m[i], truth.m[i], 1e-12);
  EXPECT_LT(m.rms_relative, 1e-12);
  EnvMap map = make_latlong(4, 2);
  for (size_t i = 0; i < map.pixel_count(); ++i) map.pixel(i)[0] = 1, map.pixel(i)[1] = 0.5f, map.pixel(i)[2] = 0.25f;
  apply_colour_match(map, m);
  EXPECT_NEAR(map.pixel(3)[1], 0.05 + 0.55 - 0.0075, 1e-6);
}

TEST(ColourMatch, RejectsTooFewOrDegeneratePatches) {
  std::vector<ColourPatchPair> grey(5);
  for (size_t i = 0; i < grey.size(); ++i) {
    const double v = 0.1 * double(i + 1);
    grey[i].probe = {v, v, v};
    grey[i].plate = {v, v, v};
  }
  EXPECT_THROW(fit_colour_match(grey), InputError);  // greys do not span RGB
  grey.resize(2);
  EXPECT_THROW(fit_colour_match(grey), InputError);
}

TEST(ColourMatch, ReadsPatchCsvAndNamesTheBadLine) {
  const std::string path = ::testing::TempDir() + "/patches.csv";
  std::ofstream(path) << "probe_r,probe_g,probe_b,plate_r,plate_g,plate_b\n1,0,0,0.9,0.05,0\n0,1,0,0.1,1,0\n0,0,1,x,0,1\n";
  try {
    read_colour_patches_csv(path);
    FAIL() << "a bad number was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("patches.csv:4"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace lp
