// The contract of sampling/sampler.h, checked for every method: exact count, power kept,
// unit directions, unique ids, bad input rejected, a known one-pixel answer, convergence
// and accuracy on real probes (scored by the accuracy module).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <set>
#include <string>

#include "core/accuracy.h"
#include "core/envmap.h"
#include "core/error.h"
#include "core/image_io.h"
#include "eval/synthetic_scene.h"
#include "sampling/sampler.h"

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;

bool not_implemented(const InputError& e) {
  return std::string(e.what()).find("not implemented yet") != std::string::npos;
}

// Skips the test while a method is still a placeholder.
#define MAKE_OR_SKIP(var, method)                                                      \
  std::unique_ptr<Sampler> var;                                                        \
  try {                                                                                \
    var = make_sampler(method);                                                        \
  } catch (const InputError& e) {                                                      \
    if (not_implemented(e)) GTEST_SKIP() << to_string(method) << " not implemented yet"; \
    throw;                                                                             \
  }

#define PREPARE_OR_SKIP(sampler, map)                                                          \
  try {                                                                                        \
    (sampler)->prepare(map);                                                                   \
  } catch (const InputError& e) {                                                              \
    if (not_implemented(e)) GTEST_SKIP() << to_string(GetParam()) << " not implemented yet"; \
    throw;                                                                                     \
  }

const EnvMap& scene_map() {
  static const EnvMap map = render_scene(describe_scene(), Layout::LatLong, 256, 128);
  return map;
}

// Empty *why: the map. Otherwise the reason to skip (data or image I/O not there yet);
// any other read failure is a test failure.
EnvMap read_or_skip_reason(const std::string& path, std::string* why) {
  if (!std::filesystem::exists(path)) {
    *why = path + " is missing";
    return {};
  }
  try {
    return read_envmap(path);
  } catch (const InputError& e) {
    if (!not_implemented(e)) throw;
    *why = e.what();
    return {};
  }
}

#define READ_OR_SKIP(var, path)                              \
  std::string var##_why;                                     \
  const EnvMap var = read_or_skip_reason(path, &var##_why); \
  if (!var##_why.empty()) GTEST_SKIP() << var##_why;

size_t allowed_slack(Method m) { return m == Method::Q2Tree ? 3 : 0; }
// The Q2-tree starts from the 12 HEALPix base quads and rejects fewer lights (InputError),
// a documented exception to "any n > 0" of sampler.h.
int fewest_lights(Method m) { return m == Method::Q2Tree ? 12 : 1; }

AccuracyOptions quick_accuracy() {
  AccuracyOptions o;
  o.shadowed = false;
  return o;
}

class SamplerContract : public ::testing::TestWithParam<Method> {};

TEST_P(SamplerContract, GivesExactlyNLights) {
  MAKE_OR_SKIP(s, GetParam());
  PREPARE_OR_SKIP(s, scene_map());
  for (int n : {1, 2, 7, 12, 13, 64, 300, 1024}) {
    if (n < fewest_lights(GetParam())) {
      EXPECT_THROW(s->place(n), InputError);
      continue;
    }
    const auto lights = s->place(n);
    const double diff = std::abs(double(lights.size()) - n);
    EXPECT_LE(diff, double(allowed_slack(GetParam()))) << "n = " << n << " gave " << lights.size();
  }
}

TEST_P(SamplerContract, KeepsTheMapsPowerPerChannel) {
  MAKE_OR_SKIP(s, GetParam());
  PREPARE_OR_SKIP(s, scene_map());
  const auto want = total_power(scene_map());
  for (int n : {fewest_lights(GetParam()), 16, 1000}) {
    const auto got = total_power(s->place(n));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-5 * want[c]) << "n = " << n << " channel " << c;
  }
}

TEST_P(SamplerContract, GivesUnitDirectionsUniqueIdsAndPositiveSolidAngles) {
  MAKE_OR_SKIP(s, GetParam());
  PREPARE_OR_SKIP(s, scene_map());
  const auto lights = s->place(500);
  std::set<uint64_t> ids;
  for (const Light& l : lights) {
    EXPECT_NEAR(length(l.direction), 1.0, 1e-9);
    EXPECT_GT(l.solid_angle, 0.0);
    for (double v : l.rgb) EXPECT_TRUE(std::isfinite(v) && v >= 0);
    ids.insert(l.id);
  }
  EXPECT_EQ(ids.size(), lights.size());
}

TEST_P(SamplerContract, RejectsANonPositiveLightCount) {
  MAKE_OR_SKIP(s, GetParam());
  PREPARE_OR_SKIP(s, scene_map());
  EXPECT_THROW(s->place(0), InputError);
  EXPECT_THROW(s->place(-5), InputError);
  EXPECT_THROW(sample(scene_map(), 0, GetParam()), InputError);
}

TEST_P(SamplerContract, RejectsABlackMap) {
  MAKE_OR_SKIP(s, GetParam());
  const EnvMap black = make_latlong(128, 64);
  try {
    s->prepare(black);
    FAIL() << "a black map was accepted";
  } catch (const InputError& e) {
    if (not_implemented(e)) GTEST_SKIP();
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << "one-line message";
  }
}

TEST_P(SamplerContract, RejectsAMapWithNaN) {
  MAKE_OR_SKIP(s, GetParam());
  EnvMap map = make_latlong(128, 64);
  std::fill(map.rgb.begin(), map.rgb.end(), 1.0f);
  map.pixel(1000)[1] = std::numeric_limits<float>::quiet_NaN();
  try {
    s->prepare(map);
    FAIL() << "a NaN map was accepted";
  } catch (const InputError& e) {
    if (not_implemented(e)) GTEST_SKIP();
  }
}

// Values near float's limit (3e38) overflow a sampler's single-precision sums: the map is
// then refused saying so (pharr and mediancut said "no positive luminance"), or sampled
// into finite lights.
TEST_P(SamplerContract, AMapNearFloatsLimitIsRefusedAsSuchOrSampledFinitely) {
  MAKE_OR_SKIP(s, GetParam());
  EnvMap map = make_latlong(128, 64);
  for (int v = 20; v < 30; ++v)
    for (int u = 40; u < 50; ++u) std::fill_n(map.pixel(size_t(v) * 128 + size_t(u)), 3, 3e38f);
  try {
    s->prepare(map);
    for (const Light& l : s->place(16))
      for (int c = 0; c < 3; ++c) EXPECT_TRUE(std::isfinite(l.rgb[c])) << "light " << l.id;
  } catch (const InputError& e) {
    if (not_implemented(e)) GTEST_SKIP();
    const std::string what = e.what();
    EXPECT_NE(what.find("the map's power overflows single precision"), std::string::npos) << what;
  }
}

// All lights of a one-pixel map sit on that pixel and carry exactly its power.
void expect_on_single_pixel(const std::vector<Light>& lights, const EnvMap& map, size_t pixel) {
  const double one_pixel = 0.36 * M_PI / 180;  // 1024 x 512: 360 / 1024 deg
  const Vec3 d = pixel_direction(map, pixel);
  for (const Light& l : lights) {
    if (l.luminance() > 0) {
      EXPECT_LT(angle_between(l.direction, d), one_pixel) << "light " << l.id;
    }
  }
  const auto want = total_power(map), got = total_power(lights);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-5 * want[c]);
}

TEST_P(SamplerContract, PutsEveryLightOfASingleLitPixelOnThatPixel) {
  MAKE_OR_SKIP(s, GetParam());
  EnvMap map = make_latlong(1024, 512);
  const size_t pixel = size_t(140) * 1024 + 333;
  map.pixel(pixel)[0] = 5000.0f;
  map.pixel(pixel)[1] = 4000.0f;
  map.pixel(pixel)[2] = 3000.0f;
  PREPARE_OR_SKIP(s, map);
  for (int n : {fewest_lights(GetParam()), 16, 256}) {
    SCOPED_TRACE(n);
    expect_on_single_pixel(s->place(n), map, pixel);
  }
}

TEST_P(SamplerContract, FindsTheOneLitPixelOfThreeJsSpot1Lux) {
  READ_OR_SKIP(map, kData + "/probes-threejs-spot-and-cube/spot1Lux.hdr");
  ASSERT_EQ(map.width, 1024);
  ASSERT_EQ(map.height, 512);
  // PROVENANCE.md: the only lit pixel is (x = 597, y = 213), total 0.959.
  const size_t pixel = size_t(213) * 1024 + 597;
  EXPECT_NEAR(total_luminance_power(map), 0.959, 0.001);
  MAKE_OR_SKIP(s, GetParam());
  PREPARE_OR_SKIP(s, map);
  for (int n : {fewest_lights(GetParam()), 64}) {
    SCOPED_TRACE(n);
    expect_on_single_pixel(s->place(n), map, pixel);
  }
}

// Diffuse error at n = 1024 at most half that at n = 64.
void expect_converges(Sampler& s, const EnvMap& map) {
  const auto ref = make_accuracy_reference(map, quick_accuracy());
  const double e64 = light_error(ref, s.place(64)).diffuse;
  const double e1024 = light_error(ref, s.place(1024)).diffuse;
  EXPECT_LE(e1024, 0.5 * e64) << "diffuse error " << e64 << " at 64 lights, " << e1024 << " at 1024";
}

TEST_P(SamplerContract, ConvergesOnTheProceduralScene) {
  MAKE_OR_SKIP(s, GetParam());
  PREPARE_OR_SKIP(s, scene_map());
  expect_converges(*s, scene_map());
}

TEST_P(SamplerContract, ConvergesOnGrace) {
  READ_OR_SKIP(map, kData + "/probes-probulator-latlong256/grace.hdr");
  MAKE_OR_SKIP(s, GetParam());
  PREPARE_OR_SKIP(s, map);
  expect_converges(*s, map);
}

void expect_accurate_at_1024(Sampler& s, const EnvMap& map) {
  const auto ref = make_accuracy_reference(map, quick_accuracy());
  const auto e = light_error(ref, s.place(1024));
  EXPECT_LT(e.diffuse, 0.015);
  ASSERT_FALSE(e.glossy.empty());
  EXPECT_LT(e.glossy[0], 0.05) << "glossy s = " << ref.options.glossy_exponents[0];
}

TEST_P(SamplerContract, IsAccurateAt1024LightsOnGrace) {
  READ_OR_SKIP(map, kData + "/probes-probulator-latlong256/grace.hdr");
  MAKE_OR_SKIP(s, GetParam());
  PREPARE_OR_SKIP(s, map);
  expect_accurate_at_1024(*s, map);
}

TEST_P(SamplerContract, IsAccurateAt1024LightsOnCourtyard) {
  READ_OR_SKIP(map, kData + "/probes-blender-studiolights/courtyard.exr");
  MAKE_OR_SKIP(s, GetParam());
  PREPARE_OR_SKIP(s, map);
  expect_accurate_at_1024(*s, map);
}

INSTANTIATE_TEST_SUITE_P(AllMethods, SamplerContract, ::testing::ValuesIn(all_methods()),
                         [](const ::testing::TestParamInfo<Method>& info) { return std::string(to_string(info.param)); });

}  // namespace
}  // namespace lp
