#include "core/openexr_cube.h"

#include <ImfChannelList.h>
#include <ImfEnvmap.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <limits>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/image_io.h"
#include "tests/core/test_files.h"

namespace lp {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A smooth, asymmetric sky in the world frame: bright towards (0.6, 0.3, 0.74), on none of
// the axes, so that a mirror or a turn of the frame moves it. Its integral over the sphere
// is exact: 0.1 x 4 pi + (ch + 1) x 2 pi / 5 (the cosine lobe to the 4th power).
double sky(Vec3 d, int ch) {
  const double c = std::max(0.0, dot(normalize(d), normalize(Vec3{0.6, 0.3, 0.74})));
  return 0.1 + std::pow(c, 4) * (ch + 1);
}
double sky_power(int ch) { return 0.4 * kPi + (ch + 1) * 0.4 * kPi; }

// The sky as OpenEXR lays a cube out, each texel at the direction ImfEnvmap.h gives it.
std::vector<float> sky_cube(int n) {
  const Imath::Box2i dw(Imath::V2i(0, 0), Imath::V2i(n - 1, 6 * n - 1));
  std::vector<float> rgb(size_t(n) * size_t(6 * n) * 3);
  for (int f = 0; f < 6; ++f)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const Imath::V2f pos{float(i), float(j)};
        const Imath::V3f e = Imf::CubeMap::direction(Imf::CubeMapFace(f), dw, pos);
        const Imath::V2f p = Imf::CubeMap::pixelPosition(Imf::CubeMapFace(f), dw, pos);
        const Vec3 world = world_from_openexr({e.x, e.y, e.z});
        for (int ch = 0; ch < 3; ++ch)
          rgb[3 * (size_t(std::lround(p.y)) * size_t(n) + size_t(std::lround(p.x))) + size_t(ch)] = float(sky(world, ch));
      }
  return rgb;
}

// Relative RMS of a latlong map against the sky at its pixel centres; `mirrored` compares
// pixel u with the sky at pixel W - 1 - u (what the wrong handedness gives).
double relative_rms(const EnvMap& m, bool mirrored = false) {
  double e2 = 0, ref = 0;
  for (size_t i = 0; i < m.pixel_count(); ++i) {
    const size_t u = i % size_t(m.width), v = i / size_t(m.width);
    const size_t at = mirrored ? v * size_t(m.width) + (size_t(m.width) - 1 - u) : i;
    const double truth = sky(pixel_direction(m, at), 2);
    e2 += std::pow(m.pixel(i)[2] - truth, 2);
    ref += truth;
  }
  return std::sqrt(e2 / double(m.pixel_count())) / (ref / double(m.pixel_count()));
}

std::array<double, 3> power(const EnvMap& m) {
  std::array<double, 3> p{0, 0, 0};
  for (size_t i = 0; i < m.pixel_count(); ++i)
    for (int ch = 0; ch < 3; ++ch) p[size_t(ch)] += m.pixel(i)[ch] * pixel_solid_angle(m, i);
  return p;
}

void write_cube_file(const std::string& path, int width, int height, std::vector<float> rgb, const char* layout) {
  Imf::Header header(width, height);
  for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
  Imf::addEnvmap(header, Imf::ENVMAP_CUBE);
  if (layout) header.insert("lightprobe.layout", Imf::StringAttribute(layout));  // as exrenvmap copies it
  Imf::OutputFile out(path.c_str(), header);
  Imf::FrameBuffer fb;
  const size_t xs = 3 * sizeof(float), ys = xs * size_t(width);
  fb.insert("R", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&rgb[0]), xs, ys));
  fb.insert("G", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&rgb[1]), xs, ys));
  fb.insert("B", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&rgb[2]), xs, ys));
  out.setFrameBuffer(fb);
  out.writePixels(height);
}

TEST(OpenExrCube, ItsLatlongHoldsTheSkyAndItsPower) {
  const int n = 64;
  const EnvMap m = openexr_cube_to_latlong(sky_cube(n), n);
  ASSERT_EQ(m.layout, Layout::LatLong);
  ASSERT_EQ(m.width, 4 * n);
  ASSERT_EQ(m.height, 2 * n);
  const double rel = relative_rms(m), mirrored = relative_rms(m, true);
  std::printf("  OpenEXR cube -> latlong: relative RMS %.5f (against the mirrored sky %.4f)\n", rel, mirrored);
  EXPECT_LT(rel, 0.005);
  EXPECT_GT(mirrored, 20 * rel) << "the frame is mirrored or turned";
  const auto p = power(m);
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(p[size_t(ch)] / sky_power(ch), 1.0, 0.003) << "channel " << ch;
}

TEST(OpenExrCube, AFileWhoseEnvmapSaysCubeIsReadAsTheLatlongItHolds) {
  const std::string dir = test_files::temp_dir("OpenExrCube");
  const int n = 32;
  // A stale lightprobe.layout beside the attribute, as exrenvmap leaves it: the attribute wins.
  write_cube_file(dir + "cube.exr", n, 6 * n, sky_cube(n), "latlong");
  const EnvMap m = read_envmap(dir + "cube.exr");
  EXPECT_EQ(m.layout, Layout::LatLong);
  ASSERT_EQ(m.width, 4 * n);
  ASSERT_EQ(m.height, 2 * n);
  EXPECT_LT(relative_rms(m), 0.01);
  const EnvMap direct = openexr_cube_to_latlong(sky_cube(n), n);
  EXPECT_EQ(m.rgb, direct.rgb);
  // Read as a layout the user names (--in-layout), the file's pixels are taken as they are.
  ReadMapOptions as_pixels;
  as_pixels.layout = Layout::Hemisphere;
  const EnvMap raw = read_envmap(dir + "cube.exr", as_pixels);
  EXPECT_EQ(raw.width, n);
  EXPECT_EQ(raw.height, 6 * n);
}

TEST(OpenExrCube, ACubeOfTheWrongShapeOrWithANaNIsRefusedNamingTheFile) {
  const std::string dir = test_files::temp_dir("OpenExrCube");
  write_cube_file(dir + "short.exr", 16, 80, std::vector<float>(16 * 80 * 3, 1.0f), nullptr);
  const std::string shape = test_files::input_error([&] { read_envmap(dir + "short.exr"); });
  EXPECT_NE(shape.find("short.exr"), std::string::npos) << shape;
  EXPECT_NE(shape.find("N x 6N"), std::string::npos) << shape;
  EXPECT_NE(shape.find("16x80"), std::string::npos) << shape;
  std::vector<float> cube = sky_cube(16);
  cube[3 * (16 * 40 + 5) + 1] = std::numeric_limits<float>::quiet_NaN();
  write_cube_file(dir + "nan.exr", 16, 96, cube, nullptr);
  const std::string nan = test_files::input_error([&] { read_envmap(dir + "nan.exr"); });
  EXPECT_NE(nan.find("nan.exr"), std::string::npos) << nan;
  EXPECT_NE(nan.find("pixel (5, 40) of the cube image is NaN"), std::string::npos) << nan;
}

// OpenEXR's own tool is the reference for its convention: exrenvmap turns a lightprobe
// latlong map into a cube, and that cube must read back as the map. The map is 4x finer than
// the cube's latlong: exrenvmap reads a latlong with OpenEXR's pixel centres, on the poles
// and at +-pi, ours half a pixel in; at 64 rows that stretch alone was 5 % RMS (1.5 % of the
// power), at 256 it is below exrenvmap's own filtering.
TEST(OpenExrCube, ExrenvmapsCubeOfAMapReadsBackAsThatMap) {
  if (std::system("command -v exrenvmap >/dev/null 2>&1") != 0) GTEST_SKIP() << "exrenvmap (Debian openexr) not installed";
  const std::string dir = test_files::temp_dir("OpenExrCube");
  EnvMap map = make_latlong(512, 256);
  for (size_t i = 0; i < map.pixel_count(); ++i)
    for (int ch = 0; ch < 3; ++ch) map.pixel(i)[ch] = float(sky(pixel_direction(map, i), ch));
  write_envmap(dir + "map.exr", map);
  ASSERT_EQ(std::system(("exrenvmap -c -w 32 " + dir + "map.exr " + dir + "cube.exr >/dev/null 2>&1").c_str()), 0);
  const EnvMap back = read_envmap(dir + "cube.exr");
  ASSERT_EQ(back.width, 128);
  ASSERT_EQ(back.height, 64);
  const double rel = relative_rms(back), mirrored = relative_rms(back, true);
  std::printf("  exrenvmap's cube read back: relative RMS %.4f (against the mirrored map %.4f)\n", rel, mirrored);
  EXPECT_LT(rel, 0.025);
  EXPECT_GT(mirrored, 5 * rel);
  const auto p = power(back);
  for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(p[size_t(ch)] / sky_power(ch), 1.0, 0.01) << "channel " << ch;
}

}  // namespace
}  // namespace lp
