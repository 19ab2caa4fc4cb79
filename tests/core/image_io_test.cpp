#include "core/image_io.h"

#include <png.h>
#include <opencv2/imgcodecs.hpp>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfMultiPartOutputFile.h>
#include <ImfOutputFile.h>
#include <ImfInputFile.h>
#include <ImfOutputPart.h>
#include <ImfPartType.h>
#include <ImfStandardAttributes.h>
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <tuple>
#include <vector>

#include "core/error.h"
#include "core/lazy_libs.h"
#include "core/picture_io.h"
#include "core/chromaticities.h"
#include "core/envmap.h"
#include "core/warnings.h"
#include "tests/core/test_files.h"

extern "C" {
#include <chealpix.h>
}

namespace fs = std::filesystem;

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;

using test_files::read_bytes;
using test_files::write_bytes;
std::string temp_dir() { return test_files::temp_dir("lightprobe_image_io"); }

void truncate_to_half(const std::string& from, const std::string& to) {
  const std::string bytes = read_bytes(from);
  ASSERT_GT(bytes.size(), 16u);
  write_bytes(to, bytes.substr(0, bytes.size() / 2));
}

// Runs `f`, expects an InputError of one line that contains every fragment; returns it.
std::string expect_input_error(const std::function<void()>& f, std::initializer_list<std::string> fragments) {
  try {
    f();
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\r'), std::string::npos) << msg;
    for (const auto& frag : fragments) EXPECT_NE(msg.find(frag), std::string::npos) << "'" << frag << "' not in: " << msg;
    return msg;
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected InputError, got other exception: " << e.what();
    return {};
  }
  ADD_FAILURE() << "expected InputError, nothing thrown";
  return {};
}

// Radiance-like values over several decades, deterministic.
void fill_random(EnvMap& map, unsigned seed, double lo_exp = -3, double hi_exp = 4) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> e(lo_exp, hi_exp);
  for (float& v : map.rgb) v = float(std::pow(10.0, e(rng)));
}

size_t count_temp_files(const std::string& dir) {
  size_t n = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    if (entry.path().filename().string().find(".tmp-") != std::string::npos) ++n;
  return n;
}

// Renames the "lightprobe.layout" attribute of an EXR written by write_envmap so the file
// looks foreign (same length, so the header stays valid).
void strip_layout_attribute(const std::string& path) {
  std::string bytes = read_bytes(path);
  const size_t at = bytes.find("lightprobe.layout");
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, 17, "foreign.attribute");
  write_bytes(path, bytes);
}

template <class T>
void put(std::string& s, T v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof v);  // EXR is little-endian, as the test host
}

struct ExrChannel {
  std::string name;  // channels must be given in alphabetical order
  int type;          // 1 = HALF, 2 = FLOAT
  std::function<uint32_t(int x, int y)> bits;  // raw bits of each sample
};

// An uncompressed scanline OpenEXR file written from the file-format specification, so the
// reader is checked against bytes it did not produce.
std::string handmade_exr(int w, int h, const std::vector<ExrChannel>& channels) {
  std::string s = "\x76\x2f\x31\x01";
  put<int32_t>(s, 2);
  auto attr = [&](const std::string& name, const std::string& type, const std::string& value) {
    s += name + '\0' + type + '\0';
    put<int32_t>(s, int32_t(value.size()));
    s += value;
  };
  std::string ch;
  for (const auto& c : channels) {
    ch += c.name + '\0';
    put<int32_t>(ch, c.type);
    put<uint32_t>(ch, 0);  // pLinear + reserved
    put<int32_t>(ch, 1);
    put<int32_t>(ch, 1);
  }
  ch += '\0';
  std::string box;
  for (int v : {0, 0, w - 1, h - 1}) put<int32_t>(box, v);
  std::string one, center;
  put<float>(one, 1.0f);
  put<float>(center, 0.0f);
  put<float>(center, 0.0f);
  attr("channels", "chlist", ch);
  attr("compression", "compression", std::string(1, '\0'));
  attr("dataWindow", "box2i", box);
  attr("displayWindow", "box2i", box);
  attr("lineOrder", "lineOrder", std::string(1, '\0'));
  attr("pixelAspectRatio", "float", one);
  attr("screenWindowCenter", "v2f", center);
  attr("screenWindowWidth", "float", one);
  s += '\0';
  size_t line_bytes = 0;
  for (const auto& c : channels) line_bytes += size_t(w) * (c.type == 1 ? 2 : 4);
  const size_t first = s.size() + 8 * size_t(h);
  for (int y = 0; y < h; ++y) put<uint64_t>(s, first + size_t(y) * (8 + line_bytes));
  for (int y = 0; y < h; ++y) {
    put<int32_t>(s, y);
    put<int32_t>(s, int32_t(line_bytes));
    for (const auto& c : channels)
      for (int x = 0; x < w; ++x) {
        if (c.type == 1)
          put<uint16_t>(s, uint16_t(c.bits(x, y)));
        else
          put<uint32_t>(s, c.bits(x, y));
      }
  }
  return s;
}

uint32_t float_bits(float v) {
  uint32_t u;
  std::memcpy(&u, &v, 4);
  return u;
}

// ----------------------------------------------------------------------------- OpenEXR

TEST(ImageIo, ExrFloatRoundTripIsExactAndKeepsLayoutUnitsAndMask) {
  const std::string dir = temp_dir();
  // 2:1 hemisphere: inference alone would call it latlong, so reading it back as
  // hemisphere proves the attribute is written and read.
  EnvMap map = make_hemisphere(40, 20);
  fill_random(map, 1);
  map.units = Units::Radiance;
  map.valid.assign(map.pixel_count(), 1);
  for (size_t i = 0; i < map.pixel_count(); i += 7) map.valid[i] = 0;
  write_envmap(dir + "m.exr", map);
  const EnvMap back = read_envmap(dir + "m.exr");
  EXPECT_EQ(back.layout, Layout::Hemisphere);
  EXPECT_EQ(back.units, Units::Radiance);
  ASSERT_EQ(back.width, 40);
  ASSERT_EQ(back.height, 20);
  EXPECT_EQ(back.rgb, map.rgb);
  EXPECT_EQ(back.valid, map.valid);
  EXPECT_EQ(count_temp_files(dir), 0u);
}

// A fused photo's record (stop 58): its lens vignetting divided out, and the EXIF turn its
// bracket was shown by. Both survive .exr and .hdr; .pfm, which cannot hold them, is refused.
TEST(ImageIo, AFusedPhotosVignettingAndExifTurnAreRecorded) {
  const std::string dir = temp_dir();
  RgbImage img;
  img.width = 3, img.height = 2;
  img.rgb.assign(18, 0.5f);
  img.vignetting_corrected = true;
  img.orientation = 6;
  for (const char* ext : {".exr", ".hdr"}) {
    write_rgb_image(dir + "photo" + ext, img);
    const RgbImage back = read_rgb_image(dir + "photo" + ext);
    EXPECT_TRUE(back.vignetting_corrected) << ext;
    EXPECT_EQ(back.orientation, 6) << ext;
  }
  const RgbImage plain = read_rgb_image((write_rgb_image(dir + "plain.exr", RgbImage{3, 2, img.rgb}), dir + "plain.exr"));
  EXPECT_FALSE(plain.vignetting_corrected);
  EXPECT_EQ(plain.orientation, 1);
  EXPECT_NE(test_files::input_error([&] { write_rgb_image(dir + "photo.pfm", img); }).find("cannot write: .pfm"),
            std::string::npos);
  img.vignetting_corrected = false;
  EXPECT_NE(test_files::input_error([&] { write_rgb_image(dir + "photo.pfm", img); }).find("EXIF Orientation"),
            std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir + "photo.pfm"));
  // Turned back to the sensor's frame: 6 (a quarter turn clockwise to show) undone by 8.
  RgbImage shown;
  shown.width = 2, shown.height = 3;
  for (int i = 0; i < 6; ++i) shown.rgb.insert(shown.rgb.end(), {float(i), 0, 0});
  shown.orientation = 6;
  const RgbImage stored = turned_back_to_sensor(shown);
  EXPECT_EQ(stored.width, 3);
  EXPECT_EQ(stored.orientation, 1);
  CameraImage again;
  again.width = stored.width, again.height = stored.height, again.rgb = stored.rgb;
  EXPECT_EQ(turned_as_shown(again, 6).rgb, shown.rgb);
}

// Where probe register put the ball (EnvMap::mirror_ball) survives every writer of photos to
// the 17th digit, turns with the pixels, and a value no ball can have is refused, naming it.
TEST(ImageIo, ARegisteredBallIsRecordedTurnedAndChecked) {
  const std::string dir = temp_dir();
  RgbImage img;
  img.width = 6, img.height = 4;
  img.rgb.assign(3 * 24, 0.25f);
  img.mirror_ball = std::array<double, 3>{2.5, 1.75, 1.0 / 3.0};
  for (const char* ext : {".exr", ".hdr"}) {
    write_rgb_image(dir + "ball" + ext, img);
    EXPECT_EQ(read_rgb_image(dir + "ball" + ext).mirror_ball, img.mirror_ball) << ext;
  }
  write_code_image(dir + "ball.png", img, 8);
  EXPECT_EQ(read_rgb_image(dir + "ball.png").mirror_ball, img.mirror_ball);
  EXPECT_EQ(read_camera_image(dir + "ball.png").mirror_ball, img.mirror_ball);
  write_code_image(dir + "ball16.png", img, 16);
  EXPECT_EQ(read_camera_image(dir + "ball16.png").mirror_ball, img.mirror_ball);
  EXPECT_FALSE(read_rgb_image((write_code_image(dir + "none.png", RgbImage{6, 4, img.rgb}, 8), dir + "none.png"))
                   .mirror_ball.has_value());
  // Pixels without data (beyond a registered photo's edge) are transparent in the PNG, read
  // back as unseen; a format without alpha is refused rather than writing them black.
  RgbImage masked = img;
  masked.valid.assign(24, 1);
  masked.valid[5] = masked.valid[17] = 0;
  for (int bits : {8, 16}) {
    write_code_image(dir + "masked.png", masked, bits);
    const CameraImage back = read_camera_image(dir + "masked.png");
    EXPECT_EQ(back.valid, masked.valid) << bits;
    EXPECT_EQ(back.bit_depth, bits);
    EXPECT_EQ(back.rgb, read_camera_image(dir + (bits == 8 ? "ball.png" : "ball16.png")).rgb) << bits;
    EXPECT_EQ(back.mirror_ball, img.mirror_ball);
  }
  EXPECT_NE(test_files::input_error([&] { write_code_image(dir + "masked.tif", masked, 8); })
                .find("masked.tif: .tif holds pixels without data, which only a PNG (its alpha) can mark"),
            std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir + "masked.tif"));
  // A fused photo's own mask (pixels no frame saw) reads back as it was, without the warning
  // that a foreign file's alpha gets.
  std::vector<std::string> warnings;
  const WarningSink before = set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  write_rgb_image(dir + "masked.exr", masked);
  EXPECT_EQ(read_rgb_image(dir + "masked.exr").valid, masked.valid);
  set_warning_sink(before);
  EXPECT_TRUE(warnings.empty()) << warnings[0];
  // Turned: a marker at the ball's centre pixel stays at the turned ball's centre.
  RgbImage shown = img;
  shown.orientation = 6;
  shown.rgb[3 * (1 * 6 + 2)] = 9;  // the pixel holding (2.5, 1.75): column 2, row 1
  const RgbImage stored = turned_back_to_sensor(shown);
  ASSERT_TRUE(stored.mirror_ball.has_value());
  const auto [sx, sy, sr] = *stored.mirror_ball;
  EXPECT_EQ(sr, 1.0 / 3.0);
  EXPECT_EQ(stored.rgb[3 * (size_t(sy) * size_t(stored.width) + size_t(sx))], 9.0f) << sx << " " << sy;
  CameraImage again;
  again.width = stored.width, again.height = stored.height, again.rgb = stored.rgb, again.mirror_ball = stored.mirror_ball;
  EXPECT_EQ(turned_as_shown(again, 6).mirror_ball, img.mirror_ball);
  // A record no ball can have: refused, naming the file and the record.
  write_rgb_image(dir + "bad.hdr", img);
  std::string bytes = read_bytes(dir + "bad.hdr");
  const size_t at = bytes.find("LIGHTPROBE_MIRROR_BALL=");
  ASSERT_NE(at, std::string::npos);
  for (const char* bad : {"2.5 1.75", "2.5 1.75 -1", "2.5 nan 1", "60 1 2", "1 2 3 4"}) {
    std::string b = bytes;
    b.replace(at, b.find('\n', at) - at, std::string("LIGHTPROBE_MIRROR_BALL=") + bad);
    write_bytes(dir + "bad.hdr", b);
    const std::string e = test_files::input_error([&] { read_rgb_image(dir + "bad.hdr"); });
    EXPECT_NE(e.find("bad.hdr: bad LIGHTPROBE_MIRROR_BALL value"), std::string::npos) << bad << ": " << e;
  }
}

TEST(ImageIo, ExrHalfRoundTripIsWithinHalfPrecision) {
  const std::string dir = temp_dir();
  EnvMap map = make_latlong(64, 32);
  fill_random(map, 2, -3, 4.6);  // up to ~4e4, inside the half range
  map.units = Units::Radiance;
  map.valid.assign(map.pixel_count(), 0);
  for (size_t i = 0; i < map.pixel_count(); i += 3) map.valid[i] = 1;
  write_envmap(dir + "h.exr", map, {ExrPixelType::Half});
  const EnvMap back = read_envmap(dir + "h.exr");
  EXPECT_EQ(back.layout, Layout::LatLong);
  EXPECT_EQ(back.units, Units::Radiance);
  EXPECT_EQ(back.valid, map.valid);
  ASSERT_EQ(back.rgb.size(), map.rgb.size());
  double worst = 0;
  for (size_t i = 0; i < map.rgb.size(); ++i)
    worst = std::max(worst, std::fabs(double(back.rgb[i]) - map.rgb[i]) / map.rgb[i]);
  EXPECT_LE(worst, std::ldexp(1.0, -11) * 1.0001);  // half: 10-bit mantissa, rounded
  EXPECT_GT(worst, 0.0);                            // and it really was stored as half
  EXPECT_LT(fs::file_size(dir + "h.exr"), 64 * 32 * 3 * 4u);
}

TEST(ImageIo, ExrHalfRefusesValuesBeyondTheHalfRangeInsteadOfWritingInfinity) {
  const std::string dir = temp_dir();
  EnvMap map = make_latlong(8, 4);
  map.pixel(9)[1] = 1e5f;
  expect_input_error([&] { write_envmap(dir + "big.exr", map, {ExrPixelType::Half}); }, {dir + "big.exr", "half"});
  EXPECT_FALSE(fs::exists(dir + "big.exr"));
  EXPECT_EQ(count_temp_files(dir), 0u);
}

TEST(ImageIo, ExrWithoutMaskHasNoAlphaAndAForeignAlphaMasksToo) {
  const std::string dir = temp_dir();
  EnvMap map = make_latlong(16, 8);
  fill_random(map, 3);
  write_envmap(dir + "plain.exr", map);
  EXPECT_EQ(read_bytes(dir + "plain.exr").find(std::string("A\0", 2)), std::string::npos);  // no channel "A"
  EXPECT_TRUE(read_envmap(dir + "plain.exr").valid.empty());

  map.valid.assign(map.pixel_count(), 1);
  map.valid[5] = 0;
  write_envmap(dir + "foreign.exr", map);
  strip_layout_attribute(dir + "foreign.exr");
  const EnvMap back = read_envmap(dir + "foreign.exr");
  EXPECT_EQ(back.layout, Layout::LatLong);  // inferred from 16x8
  EXPECT_EQ(back.valid, map.valid);           // since stop 35: alpha below 0.5 is no data in any file
  EXPECT_EQ(back.rgb, map.rgb);
}

TEST(ImageIo, HandmadeExrFilesReadToTheirKnownValues) {
  const std::string dir = temp_dir();
  // Half RGBA, no lightprobe attributes: 1.0 = 0x3c00, 0.5 = 0x3800, 2.0 = 0x4000; alpha 0.
  const auto half = handmade_exr(4, 2, {{"A", 1, [](int, int) { return 0u; }},
                                        {"B", 1, [](int, int) { return 0x4000u; }},
                                        {"G", 1, [](int, int) { return 0x3800u; }},
                                        {"R", 1, [](int x, int y) { return x == 1 && y == 1 ? 0x3800u : 0x3c00u; }}});
  write_bytes(dir + "half.exr", half);
  const EnvMap h = read_envmap(dir + "half.exr");
  EXPECT_EQ(h.layout, Layout::LatLong);
  EXPECT_TRUE(h.valid.empty());  // a foreign alpha of 0 everywhere is no mask
  EXPECT_EQ(h.pixel(0)[0], 1.0f);
  EXPECT_EQ(h.pixel(0)[1], 0.5f);
  EXPECT_EQ(h.pixel(0)[2], 2.0f);
  EXPECT_EQ(h.pixel(5)[0], 0.5f);

  // Float luminance only: grey.
  const auto grey = handmade_exr(8, 4, {{"Y", 2, [](int x, int y) { return float_bits(0.25f * float(y * 8 + x)); }}});
  write_bytes(dir + "y.exr", grey);
  const EnvMap g = read_envmap(dir + "y.exr");
  EXPECT_EQ(g.layout, Layout::LatLong);
  for (int i = 0; i < 32; ++i)
    for (int c = 0; c < 3; ++c) ASSERT_EQ(g.pixel(i)[c], 0.25f * float(i));

  // Neither RGB nor Y: refused, listing what is there.
  write_bytes(dir + "z.exr", handmade_exr(2, 1, {{"Z", 2, [](int, int) { return 0u; }}}));
  expect_input_error([&] { read_envmap(dir + "z.exr"); }, {dir + "z.exr", "channels: Z"});
}

// A render's multilayer EXR (Blender names its beauty pass "ViewLayer.Combined.R", ...,
// beside passes without colour such as depth): with no R, G, B of its own, the file's one
// layer that has them is read. Two such layers are refused, named: which is the light is
// not the reader's to guess.
TEST(ImageIo, TheOneColourLayerOfAMultilayerExrIsRead) {
  const std::string dir = temp_dir();
  write_bytes(dir + "layers.exr",
              handmade_exr(4, 2, {{"ViewLayer.Combined.A", 1, [](int, int) { return 0x3c00u; }},
                                  {"ViewLayer.Combined.B", 1, [](int, int) { return 0x4000u; }},
                                  {"ViewLayer.Combined.G", 1, [](int, int) { return 0x3800u; }},
                                  {"ViewLayer.Combined.R", 1, [](int x, int) { return x == 2 ? 0x3800u : 0x3c00u; }},
                                  {"ViewLayer.Depth.Z", 2, [](int, int) { return float_bits(7.0f); }}}));
  const EnvMap m = read_envmap(dir + "layers.exr");
  EXPECT_TRUE(m.valid.empty());  // the layer's alpha of 1: every pixel holds data
  EXPECT_EQ(m.pixel(0)[0], 1.0f);
  EXPECT_EQ(m.pixel(0)[1], 0.5f);
  EXPECT_EQ(m.pixel(0)[2], 2.0f);
  EXPECT_EQ(m.pixel(2)[0], 0.5f);
  write_bytes(dir + "two.exr", handmade_exr(2, 1, {{"diffuse.B", 1, [](int, int) { return 0x3c00u; }},
                                                   {"diffuse.G", 1, [](int, int) { return 0x3c00u; }},
                                                   {"diffuse.R", 1, [](int, int) { return 0x3c00u; }},
                                                   {"glossy.B", 1, [](int, int) { return 0x3c00u; }},
                                                   {"glossy.G", 1, [](int, int) { return 0x3c00u; }},
                                                   {"glossy.R", 1, [](int, int) { return 0x3c00u; }}}));
  expect_input_error([&] { read_envmap(dir + "two.exr"); }, {dir + "two.exr", "2 layers hold R, G and B ('diffuse', 'glossy')"});
}

// A multi-part EXR (a stereo pair's views, oiiotool's subimages): OpenEXR's InputFile reads
// the first part, and the reader says so in one warning rather than silently.
TEST(ImageIo, AMultiPartExrIsReadThroughItsFirstPartWithAWarning) {
  const std::string dir = temp_dir(), path = dir + "parts.exr";
  std::vector<float> first(3 * 8, 1.0f), second(3 * 8, 2.0f);
  std::vector<Imf::Header> headers(2, Imf::Header(4, 2));
  for (int p = 0; p < 2; ++p) {
    headers[size_t(p)].setName(p == 0 ? "left" : "right");
    headers[size_t(p)].setType(Imf::SCANLINEIMAGE);
    for (const char* c : {"R", "G", "B"}) headers[size_t(p)].channels().insert(c, Imf::Channel(Imf::FLOAT));
  }
  {
    Imf::MultiPartOutputFile file(path.c_str(), headers.data(), 2);
    for (int p = 0; p < 2; ++p) {
      Imf::OutputPart part(file, p);
      float* base = p == 0 ? first.data() : second.data();
      Imf::FrameBuffer fb;
      for (int c = 0; c < 3; ++c)
        fb.insert(std::string(1, "RGB"[c]), Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(base + c), 12, 48));
      part.setFrameBuffer(fb);
      part.writePixels(2);
    }
  }
  std::vector<std::string> warnings;
  const WarningSink before = set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const EnvMap m = read_envmap(path);
  set_warning_sink(before);
  EXPECT_EQ(m.pixel(5)[1], 1.0f);  // the first part's
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], path + ": 2 parts (images); the first is read");
}

// Another tool's RGBA map: pixels with alpha below 0.5 hold no data (a render's transparent
// background) and are masked, with one warning; an alpha of 0 everywhere means nothing.
TEST(ImageIo, TransparentPixelsOfOtherToolsMapsAreMaskedNotBlack) {
  const std::string dir = temp_dir();
  const auto rgba = handmade_exr(4, 2, {{"A", 1, [](int x, int) { return x < 3 ? 0x3c00u : 0u; }},
                                        {"B", 1, [](int, int) { return 0x3c00u; }},
                                        {"G", 1, [](int, int) { return 0x3c00u; }},
                                        {"R", 1, [](int x, int) { return x < 3 ? 0x3c00u : 0u; }}});
  write_bytes(dir + "rgba.exr", rgba);
  std::vector<std::string> warnings;
  const WarningSink before = set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const EnvMap m = read_envmap(dir + "rgba.exr");
  ASSERT_EQ(m.valid.size(), 8u);
  for (int i = 0; i < 8; ++i) EXPECT_EQ(m.is_valid(size_t(i)), i % 4 < 3) << i;
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], dir + "rgba.exr: 2 pixels (25 %) have alpha below 0.5: read as no data (masked), not as black");
  warnings.clear();
  write_bytes(dir + "zero.exr", handmade_exr(4, 2, {{"A", 1, [](int, int) { return 0u; }},
                                                    {"B", 1, [](int, int) { return 0x3c00u; }},
                                                    {"G", 1, [](int, int) { return 0x3c00u; }},
                                                    {"R", 1, [](int, int) { return 0x3c00u; }}}));
  EXPECT_TRUE(read_envmap(dir + "zero.exr").valid.empty());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], dir + "zero.exr: its alpha channel is 0 everywhere: ignored");
  // A file refused after all (no layout recorded, not a map's shape) says one line: no warning first.
  warnings.clear();
  write_bytes(dir + "odd.exr", handmade_exr(3, 3, {{"A", 1, [](int x, int) { return x < 2 ? 0x3c00u : 0u; }},
                                                   {"B", 1, [](int, int) { return 0x3c00u; }},
                                                   {"G", 1, [](int, int) { return 0x3c00u; }},
                                                   {"R", 1, [](int, int) { return 0x3c00u; }}}));
  expect_input_error([&] { read_envmap(dir + "odd.exr"); }, {dir + "odd.exr", "no layout recorded"});
  EXPECT_TRUE(warnings.empty());
  set_warning_sink(before);
}

TEST(ImageIo, ExrWithAnUnknownLayoutAttributeIsRefused) {
  const std::string dir = temp_dir();
  EnvMap map = make_latlong(16, 8);
  write_envmap(dir + "m.exr", map);
  std::string bytes = read_bytes(dir + "m.exr");
  const size_t at = bytes.find("latlong");  // the attribute's value
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, 7, "cubemap");
  write_bytes(dir + "m.exr", bytes);
  expect_input_error([&] { read_envmap(dir + "m.exr"); }, {dir + "m.exr", "unknown", "cubemap"});
}

std::string fmt_g17(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// CONVENTIONS.md: the probe's camera-to-world rotation is part of its metadata. It survives
// EXR and HDR to the last bit, a map made without one reads back without one, PFM (no
// metadata) drops it, and a recorded matrix that is no rotation is refused by name.
TEST(ImageIo, TheProbeRotationIsRecordedInExrAndHdrAndARecordThatIsNoRotationIsRefused) {
  const std::string dir = temp_dir();
  EnvMap map = make_latlong(16, 8);
  fill_random(map, 3);
  const Mat3 r = rotation_from_yaw_pitch_roll_deg(31.7, -12.25, 4.5);
  for (const char* ext : {".exr", ".hdr"}) {
    const std::string path = dir + "plain" + ext;
    write_envmap(path, map);
    EXPECT_FALSE(read_envmap(path).world_from_probe.has_value()) << ext;
    map.world_from_probe = r;
    write_envmap(dir + "turned" + ext, map);
    const EnvMap back = read_envmap(dir + "turned" + ext);
    ASSERT_TRUE(back.world_from_probe.has_value()) << ext;
    EXPECT_EQ(back.world_from_probe->m, r.m) << ext;  // %.17g and doubles: exact
    map.world_from_probe.reset();
  }
  // OpenImageIO, a reader that knows nothing of the header line, still reads the .hdr.
  if (std::system("command -v iinfo >/dev/null 2>&1") == 0) {
    std::string listing;
    if (FILE* p = popen(("iinfo " + dir + "turned.hdr 2>&1").c_str(), "r")) {
      char buf[512];
      while (fgets(buf, sizeof buf, p)) listing += buf;
      pclose(p);
    }
    EXPECT_NE(listing.find("16 x    8, 3 channel, float hdr"), std::string::npos) << listing;
  }
  map.world_from_probe = r;
  // A .pfm records no rotation: the map is refused there, not written without it.
  try {
    write_envmap(dir + "turned.pfm", map);
    ADD_FAILURE() << "a turned map was written to .pfm";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("records no probe rotation"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir + "turned.pfm"));
  // A matrix that is not a rotation (a scale, a reflection) is no probe orientation.
  std::string hdr = read_bytes(dir + "turned.hdr");
  const size_t at = hdr.find("LIGHTPROBE_WORLD_FROM_PROBE=");
  ASSERT_NE(at, std::string::npos);
  const size_t end = hdr.find('\n', at);
  write_bytes(dir + "scaled.hdr", hdr.substr(0, at) + "LIGHTPROBE_WORLD_FROM_PROBE=2 0 0 0 2 0 0 0 2" + hdr.substr(end));
  expect_input_error([&] { read_envmap(dir + "scaled.hdr"); }, {dir + "scaled.hdr", "not a rotation"});
  write_bytes(dir + "short.hdr", hdr.substr(0, at) + "LIGHTPROBE_WORLD_FROM_PROBE=1 0 0 0 1 0" + hdr.substr(end));
  expect_input_error([&] { read_envmap(dir + "short.hdr"); }, {dir + "short.hdr", "expected 9 numbers"});
  map.world_from_probe = Mat3{{-1, 0, 0, 0, 1, 0, 0, 0, 1}};  // a mirror image
  write_envmap(dir + "mirrored.exr", map);
  expect_input_error([&] { read_envmap(dir + "mirrored.exr"); }, {dir + "mirrored.exr", "not a rotation"});
  // In EXR it is a string attribute, which every reader knows (three.js' EXRLoader warns on
  // types it does not): the same 9 numbers as the .hdr line, here spelt out in the file.
  const std::string exr = read_bytes(dir + "turned.exr");
  EXPECT_NE(exr.find(std::string("lightprobe.world_from_probe") + '\0' + "string" + '\0'), std::string::npos);
  std::string bad = exr;
  const size_t v = bad.find(fmt_g17(r.m[0]));
  ASSERT_NE(v, std::string::npos);
  bad[v] = 'x';  // the first number unreadable, the attribute's length unchanged
  write_bytes(dir + "garbled.exr", bad);
  expect_input_error([&] { read_envmap(dir + "garbled.exr"); }, {dir + "garbled.exr", "expected 9 numbers"});
}

// ----------------------------------------------------------------------------- Radiance HDR

TEST(ImageIo, HdrRoundTripIsWithinRgbePrecisionAndKeepsMetadata) {
  const std::string dir = temp_dir();
  EnvMap map = make_hemisphere(64, 32);
  fill_random(map, 4, -4, 5);
  // Flat rows and repeated pixels exercise the run-length encoder's runs.
  for (int u = 0; u < 64; ++u)
    for (int c = 0; c < 3; ++c) map.pixel(u)[c] = 3.5f;
  for (int u = 10; u < 30; ++u) std::copy_n(map.pixel(64 + 9), 3, map.pixel(64 + u));
  map.pixel(100)[0] = 0.0f;
  map.pixel(101)[0] = map.pixel(101)[1] = map.pixel(101)[2] = 0.0f;
  map.units = Units::Radiance;
  write_envmap(dir + "m.hdr", map);
  EXPECT_LT(fs::file_size(dir + "m.hdr"), 64 * 32 * 4u);  // runs were compressed
  const EnvMap back = read_envmap(dir + "m.hdr");
  EXPECT_EQ(back.layout, Layout::Hemisphere);
  EXPECT_EQ(back.units, Units::Radiance);
  ASSERT_EQ(back.rgb.size(), map.rgb.size());
  double worst = 0;
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    const float* a = map.pixel(i);
    const float* b = back.pixel(i);
    const double mx = std::max({a[0], a[1], a[2]});
    for (int c = 0; c < 3; ++c) {
      if (mx == 0) {
        ASSERT_EQ(b[c], 0.0f);
        continue;
      }
      worst = std::max(worst, std::fabs(double(b[c]) - a[c]) / mx);
    }
  }
  // Shared exponent, 8-bit mantissas rounded: error <= max channel / 256.
  EXPECT_LE(worst, 1.0 / 256 + 1e-7);
  EXPECT_EQ(back.pixel(0)[0], 3.5f);  // exactly representable
}

TEST(ImageIo, HdrNewStyleRunLengthScanlinesDecodeToKnownValues) {
  const std::string dir = temp_dir();
  std::string f = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 8\n";
  f += std::string("\x02\x02\x00\x08", 4);
  f += std::string("\x88\x64");                                     // R: run of 8 x 100
  f += std::string("\x08\x01\x02\x03\x04\x05\x06\x07\x08", 9);      // G: 8 literals 1..8
  f += std::string("\x84\x05\x04\x06\x07\x08\x09", 7);              // B: run of 4 x 5, then 6..9
  f += std::string("\x88\x81");                                     // E: run of 8 x 129
  write_bytes(dir + "rle.hdr", f);
  const EnvMap map = read_envmap(dir + "rle.hdr", {.layout = Layout::Hemisphere});
  ASSERT_EQ(map.width, 8);
  const float b[8] = {5, 5, 5, 5, 6, 7, 8, 9};
  for (int x = 0; x < 8; ++x) {  // m * 2^(129 - 136)
    EXPECT_EQ(map.pixel(x)[0], 100.0f / 128);
    EXPECT_EQ(map.pixel(x)[1], float(x + 1) / 128);
    EXPECT_EQ(map.pixel(x)[2], b[x] / 128);
  }
}

TEST(ImageIo, HdrFlatAndOldStyleRunLengthScanlinesDecodeToKnownValues) {
  const std::string dir = temp_dir();
  // 300 wide: row 0 = one pixel, then old-style runs 43 and 1<<8 (the second code's count
  // is shifted by 8): 1 + 43 + 256 = 300. Row 1 = flat pixels.
  std::string f = "#?RGBE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 300\n";
  f += std::string("\x80\x40\x20\x81", 4);  // (1, 0.5, 0.25)
  f += std::string("\x01\x01\x01\x2b", 4);
  f += std::string("\x01\x01\x01\x01", 4);
  for (int x = 0; x < 300; ++x) {
    f += char(x % 200 + 10);
    f += char(0);
    f += char(255);
    f += char(x < 150 ? 0x82 : 0);  // exponent 0: black
  }
  write_bytes(dir + "old.hdr", f);
  ReadMapOptions hemisphere;  // 300x2 is no map's shape: say which
  hemisphere.layout = Layout::Hemisphere;
  const EnvMap map = read_envmap(dir + "old.hdr", hemisphere);
  EXPECT_EQ(map.layout, Layout::Hemisphere);
  ASSERT_EQ(map.width, 300);
  for (int x = 0; x < 300; ++x) {
    ASSERT_EQ(map.pixel(x)[0], 1.0f) << x;
    ASSERT_EQ(map.pixel(x)[1], 0.5f) << x;
    ASSERT_EQ(map.pixel(x)[2], 0.25f) << x;
    const float* p = map.pixel(300 + x);
    ASSERT_EQ(p[0], x < 150 ? float(x % 200 + 10) / 64 : 0.0f) << x;
    ASSERT_EQ(p[1], 0.0f);
    ASSERT_EQ(p[2], x < 150 ? 255.0f / 64 : 0.0f);
  }
}

TEST(ImageIo, HdrPixelsAreDividedByTheProductOfExposureLines) {
  const std::string dir = temp_dir();
  std::string f = "#?RADIANCE\nEXPOSURE=2\nFORMAT=32-bit_rle_rgbe\nEXPOSURE= 0.5\nEXPOSURE=4.0\n\n-Y 1 +X 2\n";
  f += std::string("\x80\x80\x80\x82\x40\x20\x10\x81", 8);  // (2, 2, 2) and (0.5, 0.25, 0.125)
  write_bytes(dir + "exp.hdr", f);
  const EnvMap map = read_envmap(dir + "exp.hdr");
  EXPECT_EQ(map.layout, Layout::LatLong);
  EXPECT_EQ(map.pixel(0)[0], 0.5f);
  EXPECT_EQ(map.pixel(1)[0], 0.125f);
  EXPECT_EQ(map.pixel(1)[2], 0.03125f);
}

TEST(ImageIo, HdrWithXyzePixelsOrAnotherOrientationOrNoMagicIsRefused) {
  const std::string dir = temp_dir();
  const std::string px(8, '\x40');
  write_bytes(dir + "xyz.hdr", "#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 2\n" + px);
  expect_input_error([&] { read_envmap(dir + "xyz.hdr"); }, {dir + "xyz.hdr", "XYZE"});
  write_bytes(dir + "flip.hdr", "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n+Y 1 +X 2\n" + px);
  expect_input_error([&] { read_envmap(dir + "flip.hdr"); }, {dir + "flip.hdr", "orientation", "+Y 1 +X 2"});
  write_bytes(dir + "nomagic.hdr", "FORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n" + px);
  expect_input_error([&] { read_envmap(dir + "nomagic.hdr"); }, {dir + "nomagic.hdr", "not a Radiance HDR file"});
}

TEST(ImageIo, HdrDeclaringALayoutItsSizeDoesNotFitIsRefused) {
  const std::string dir = temp_dir();
  std::string f = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\nLIGHTPROBE_LAYOUT=latlong\n\n-Y 100 +X 300\n";
  f += std::string(300 * 100 * 4, '\0');  // flat black pixels
  write_bytes(dir + "bad.hdr", f);
  expect_input_error([&] { read_envmap(dir + "bad.hdr"); }, {dir + "bad.hdr", "latlong", "300x100"});
  // The same pixels read fine once the caller overrides the layout.
  EXPECT_EQ(read_envmap(dir + "bad.hdr", {.layout = Layout::Hemisphere}).width, 300);
  // And an override that does not fit is refused too.
  expect_input_error([&] { read_envmap(dir + "bad.hdr", {.layout = Layout::Healpix}); }, {dir + "bad.hdr", "healpix"});

  std::string g = "#?RADIANCE\nLIGHTPROBE_LAYOUT=cube\n\n-Y 1 +X 2\n" + std::string(8, '\0');
  write_bytes(dir + "cube.hdr", g);
  expect_input_error([&] { read_envmap(dir + "cube.hdr"); }, {dir + "cube.hdr", "unknown", "cube"});
  std::string u = "#?RADIANCE\nLIGHTPROBE_UNITS=lux\n\n-Y 1 +X 2\n" + std::string(8, '\0');
  write_bytes(dir + "units.hdr", u);
  expect_input_error([&] { read_envmap(dir + "units.hdr"); }, {dir + "units.hdr", "units", "lux"});
}

// ----------------------------------------------------------------------------- PFM

TEST(ImageIo, PfmRoundTripIsExact) {
  const std::string dir = temp_dir();
  EnvMap map = make_latlong(30, 15);
  fill_random(map, 5, -30, 30);
  write_envmap(dir + "m.pfm", map);
  const EnvMap back = read_envmap(dir + "m.pfm");
  EXPECT_EQ(back.layout, Layout::LatLong);
  EXPECT_EQ(back.width, 30);
  EXPECT_EQ(back.rgb, map.rgb);
}

TEST(ImageIo, PfmRowsAreStoredBottomToTopInEitherByteOrder) {
  const std::string dir = temp_dir();
  // Big-endian (positive scale) colour, 2x2: stored rows are bottom first.
  auto be = [](float v) {
    uint32_t u;
    std::memcpy(&u, &v, 4);
    std::string s(4, '\0');
    for (int k = 0; k < 4; ++k) s[k] = char((u >> (24 - 8 * k)) & 0xff);
    return s;
  };
  std::string f = "PF\n2 2\n1.0\n";
  for (int i = 0; i < 12; ++i) f += be(float(i + 1));
  write_bytes(dir + "be.pfm", f);
  ReadMapOptions hemisphere;  // 2x2 is no map's shape: say which
  hemisphere.layout = Layout::Hemisphere;
  const EnvMap map = read_envmap(dir + "be.pfm", hemisphere);
  EXPECT_EQ(map.layout, Layout::Hemisphere);
  // Top-left is the first pixel of the second stored row: values 7, 8, 9.
  EXPECT_EQ(map.pixel(0)[0], 7.0f);
  EXPECT_EQ(map.pixel(0)[2], 9.0f);
  EXPECT_EQ(map.pixel(2)[0], 1.0f);  // bottom-left
  EXPECT_EQ(map.pixel(3)[2], 6.0f);

  // Little-endian grey, 2x1: replicated into three channels.
  std::string g = "Pf\n2 1\n-1.0\n";
  const float v[2] = {0.5f, 2.0f};
  g.append(reinterpret_cast<const char*>(v), sizeof v);  // the test host is little-endian
  write_bytes(dir + "grey.pfm", g);
  const EnvMap grey = read_envmap(dir + "grey.pfm");
  EXPECT_EQ(grey.layout, Layout::LatLong);
  EXPECT_EQ(grey.pixel(1)[0], 2.0f);
  EXPECT_EQ(grey.pixel(1)[1], 2.0f);
  EXPECT_EQ(grey.pixel(0)[2], 0.5f);
}

// ----------------------------------------------------------------------------- HEALPix

TEST(ImageIo, HealpixNestedIndexAndFaceXyAreInversesForEveryPixelOfNside4) {
  const int nside = 4;
  std::vector<int> seen(12 * nside * nside, 0);
  for (int f = 0; f < 12; ++f)
    for (int iy = 0; iy < nside; ++iy)
      for (int ix = 0; ix < nside; ++ix) {
        const size_t n = healpix_nested_index(nside, f, ix, iy);
        ASSERT_LT(n, seen.size());
        ++seen[n];
        int f2, x2, y2;
        healpix_face_xy(nside, n, &f2, &x2, &y2);
        EXPECT_EQ(f2, f);
        EXPECT_EQ(x2, ix);
        EXPECT_EQ(y2, iy);
      }
  EXPECT_TRUE(std::all_of(seen.begin(), seen.end(), [](int c) { return c == 1; }));
  // ix on the even bits, iy on the odd bits.
  EXPECT_EQ(healpix_nested_index(nside, 0, 1, 0), 1u);
  EXPECT_EQ(healpix_nested_index(nside, 0, 0, 1), 2u);
  EXPECT_EQ(healpix_nested_index(nside, 0, 2, 0), 4u);
  EXPECT_EQ(healpix_nested_index(nside, 3, 3, 3), 3u * 16 + 15);
}

TEST(ImageIo, HealpixFaceCornersAgreeWithChealpixGeometry) {
  // In HEALPix, (ix, iy) = (nside-1, nside-1) is a face's north corner, (0, 0) its south
  // corner: the northernmost pixel of faces 0-3 lies on ring 1, z = 1 - 1/(3 nside^2).
  const int nside = 4;
  const double z_ring1 = 1.0 - 1.0 / (3.0 * nside * nside);
  for (int f = 0; f < 4; ++f) {
    double v[3];
    pix2vec_nest64(nside, int64_t(healpix_nested_index(nside, f, nside - 1, nside - 1)), v);
    EXPECT_NEAR(v[2], z_ring1, 1e-12) << "face " << f;
  }
  for (int f = 8; f < 12; ++f) {
    double v[3];
    pix2vec_nest64(nside, int64_t(healpix_nested_index(nside, f, 0, 0)), v);
    EXPECT_NEAR(v[2], -z_ring1, 1e-12) << "face " << f;
  }
}

TEST(ImageIo, HealpixMapsRoundTripThroughTheFileLayoutInEveryFormat) {
  const std::string dir = temp_dir();
  const int nside = 4;
  EnvMap map = make_healpix(nside);
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    map.pixel(i)[0] = float(i + 1);
    map.pixel(i)[1] = 0.5f * float(i + 1);
    map.pixel(i)[2] = 1.0f;
  }
  for (const char* name : {"h.exr", "h.hdr", "h.pfm"}) {
    SCOPED_TRACE(name);
    write_envmap(dir + name, map);
    const EnvMap back = read_envmap(dir + name);
    EXPECT_EQ(back.layout, Layout::Healpix);
    EXPECT_EQ(back.nside, nside);
    ASSERT_EQ(back.width, 12 * nside * nside);
    EXPECT_EQ(back.height, 1);
    for (size_t i = 0; i < map.pixel_count(); ++i)  // i + 1 <= 192 is exact in RGBE too
      ASSERT_NEAR(back.pixel(i)[0], map.pixel(i)[0], map.pixel(i)[0] / 256) << i;
  }
  // The file image (PFM, stored bottom to top): nside wide, 12 nside tall, its pixels row
  // by row from the top the NESTED pixels in order (CONVENTIONS.md), so that a reader that
  // takes the file as a flat array of 12 nside^2 NESTED pixels reads it right.
  const std::string pfm = read_bytes(dir + "h.pfm");
  const std::string head = "PF\n4 48\n-1.0\n";
  ASSERT_EQ(pfm.substr(0, head.size()), head);
  for (const size_t p : {size_t(0), size_t(5), healpix_nested_index(nside, 7, 2, 1), size_t(191)}) {
    const size_t row = p / nside, col = p % nside;
    float r;
    std::memcpy(&r, pfm.data() + head.size() + (size_t(12 * nside - 1 - row) * nside + col) * 12, 4);
    EXPECT_EQ(r, float(p + 1)) << p;
  }
}

// A little-endian colour PFM of rows given top to bottom (PFM stores them bottom first).
void write_pfm_raw(const std::string& path, int w, int h, const std::vector<float>& rgb) {
  std::string f = "PF\n" + std::to_string(w) + " " + std::to_string(h) + "\n-1.0\n";
  for (int row = h - 1; row >= 0; --row)  // the test host is little-endian
    f.append(reinterpret_cast<const char*>(&rgb[size_t(3) * size_t(row) * size_t(w)]), size_t(12) * size_t(w));
  write_bytes(path, f);
}

// A flat healpix map, one row (or column) of 12 nside^2 NESTED pixels, as another tool would
// write one, reads as healpix with or without a recorded layout; any other flat length is refused.
TEST(ImageIo, AFlatRowOfNestedPixelsReadsAsHealpix) {
  const std::string dir = temp_dir();
  const int nside = 2, npix = 12 * nside * nside;
  for (const bool row : {true, false}) {
    SCOPED_TRACE(row ? "one row" : "one column");
    const int w = row ? npix : 1, h = row ? 1 : npix;
    std::vector<float> rgb(size_t(3) * npix);
    for (int p = 0; p < npix; ++p) rgb[3 * size_t(p)] = rgb[3 * size_t(p) + 1] = rgb[3 * size_t(p) + 2] = float(p + 1);
    write_pfm_raw(dir + "flat.pfm", w, h, rgb);
    const EnvMap map = read_envmap(dir + "flat.pfm");
    ASSERT_EQ(map.layout, Layout::Healpix);
    ASSERT_EQ(map.nside, nside);
    for (int p = 0; p < npix; ++p) ASSERT_EQ(map.pixel(size_t(p))[0], float(p + 1)) << p;
  }
  write_pfm_raw(dir + "flat47.pfm", 47, 1, std::vector<float>(3 * 47, 1.f));
  EXPECT_THROW(read_envmap(dir + "flat47.pfm"), InputError);
  ReadMapOptions as_healpix;
  as_healpix.layout = Layout::Healpix;
  write_pfm_raw(dir + "flat36.pfm", 36, 1, std::vector<float>(3 * 36, 1.f));  // 12 x 3: nside not a power of two
  EXPECT_THROW(read_envmap(dir + "flat36.pfm", as_healpix), InputError);
}

// ----------------------------------------------------------------------------- real maps

TEST(ImageIo, Spot1LuxHasExactlyOneLitPixelAt597And213) {
  const EnvMap map = read_envmap(kData + "/probes-threejs-spot-and-cube/spot1Lux.hdr");
  EXPECT_EQ(map.layout, Layout::LatLong);
  ASSERT_EQ(map.width, 1024);
  ASSERT_EQ(map.height, 512);
  size_t lit = 0, where = 0;
  for (size_t i = 0; i < map.pixel_count(); ++i)
    if (map.pixel(i)[0] != 0 || map.pixel(i)[1] != 0 || map.pixel(i)[2] != 0) ++lit, where = i;
  EXPECT_EQ(lit, 1u);
  EXPECT_EQ(where % 1024, 597u);
  EXPECT_EQ(where / 1024, 213u);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(map.pixel(where)[c], 26368.0, 26368.0 / 256);
}

TEST(ImageIo, BlenderStudioLightsReadAsLatlongWithTheirSunsAndNoRingingBelowZero) {
  for (const char* name : {"city", "courtyard", "forest", "interior", "night", "studio", "sunrise", "sunset"}) {
    SCOPED_TRACE(name);
    const std::string path = kData + "/probes-blender-studiolights/" + name + ".exr";
    const EnvMap map = read_envmap(path);
    EXPECT_EQ(map.layout, Layout::LatLong);
    EXPECT_EQ(map.width, 1024);
    EXPECT_EQ(map.height, 512);
    EXPECT_TRUE(map.valid.empty());
    EXPECT_EQ(find_bad_pixel(map, path), "");
    const float mx = *std::max_element(map.rgb.begin(), map.rgb.end());
    double mean = 0;
    for (float v : map.rgb) mean += v;
    mean /= double(map.rgb.size());
    EXPECT_GT(mean, 0.1);  // "averages about 0.5" (night is darker)
    EXPECT_LT(mean, 1.5);
    const std::string n = name;
    // PROVENANCE.md: the sun in city, interior and sunrise reaches about 3.4e4.
    if (n == "city" || n == "interior" || n == "sunrise") {
      EXPECT_GT(mx, 1e4);
      EXPECT_LT(mx, 6.5e4);
    } else {
      EXPECT_GT(mx, 50.0);
    }
  }
}

TEST(ImageIo, ProbulatorProbesReadAsSmallLatlongMaps) {
  float grace_max = 0;
  for (const char* name : {"ennis", "grace", "pisa", "uffizi", "wells"}) {
    SCOPED_TRACE(name);
    const EnvMap map = read_envmap(kData + "/probes-probulator-latlong256/" + name + ".hdr");
    EXPECT_EQ(map.layout, Layout::LatLong);
    EXPECT_EQ(map.width, 256);
    EXPECT_EQ(map.height, 128);
    const float mx = *std::max_element(map.rgb.begin(), map.rgb.end());
    EXPECT_GT(mx, 1.0f);
    if (std::string(name) == "grace") grace_max = mx;
  }
  EXPECT_GT(grace_max, 1000.0f);  // Grace Cathedral's small strong lights
}

TEST(ImageIo, PisaCubeFacesReadAsSquareImagesButAreNoMapWithoutALayout) {
  for (const char* face : {"px", "nx", "py", "ny", "pz", "nz"}) {
    SCOPED_TRACE(face);
    const std::string path = kData + "/probes-threejs-spot-and-cube/pisa_cube/" + face + ".hdr";
    const RgbImage image = read_rgb_image(path);
    EXPECT_EQ(image.width, 256);
    EXPECT_EQ(image.height, 256);
    EXPECT_GT(*std::max_element(image.rgb.begin(), image.rgb.end()), 0.1f);
    expect_input_error([&] { read_envmap(path); }, {path, "no layout recorded", "256x256", "--layout"});
  }
}

TEST(ImageIo, MemorialReferenceReadsWithAMaximumOfAbout274) {
  // A fused photograph, not a map: read as an image.
  const RgbImage map = read_rgb_image(kData + "/hdr-memorial-debevec/reference/memorial_radiance_hdrshop.hdr");
  EXPECT_EQ(map.width, 512);
  EXPECT_EQ(map.height, 768);
  EXPECT_NEAR(*std::max_element(map.rgb.begin(), map.rgb.end()), 274.0, 274.0 * 0.01);
}

TEST(ImageIo, CorruptMemorialFileIsRefusedWithOneClearLine) {
  const std::string path = kData + "/hdr-memorial-debevec/reference/memorial_CORRUPT_from_SSARCandy.hdr";
  const std::string msg = expect_input_error([&] { read_envmap(path); }, {path, "not a Radiance HDR file", "VIEW="});
  EXPECT_LT(msg.size(), 400u);
}

// ----------------------------------------------------------------------------- failures

TEST(ImageIo, TruncatedExrHdrAndPfmFilesAreRefusedWithOneLine) {
  const std::string dir = temp_dir();
  EnvMap map = make_latlong(128, 64);
  fill_random(map, 6);
  for (const char* name : {"m.exr", "m.hdr", "m.pfm"}) {
    SCOPED_TRACE(name);
    write_envmap(dir + name, map);
    const std::string cut = dir + "cut_" + name;
    truncate_to_half(dir + name, cut);
    expect_input_error([&] { read_envmap(cut); }, {cut, "truncated file"});
  }
  expect_input_error([&] { read_envmap(dir + "cut_m.hdr"); }, {"truncated file (expected 64 scanlines, read"});
  expect_input_error([&] { read_envmap(dir + "cut_m.pfm"); }, {"truncated file (expected 64 rows, read 31)"});
  // Real files cut in half: a DWAB EXR and an RLE HDR.
  truncate_to_half(kData + "/probes-blender-studiolights/city.exr", dir + "city_cut.exr");
  expect_input_error([&] { read_envmap(dir + "city_cut.exr"); }, {dir + "city_cut.exr: truncated file"});
  truncate_to_half(kData + "/hdr-memorial-debevec/reference/memorial_radiance_hdrshop.hdr", dir + "mem_cut.hdr");
  expect_input_error([&] { read_envmap(dir + "mem_cut.hdr"); }, {dir + "mem_cut.hdr", "truncated file"});
  // Only a few header bytes left.
  write_bytes(dir + "stub.exr", read_bytes(dir + "m.exr").substr(0, 40));
  expect_input_error([&] { read_envmap(dir + "stub.exr"); }, {dir + "stub.exr: truncated file"});
  write_bytes(dir + "empty.hdr", "");
  expect_input_error([&] { read_envmap(dir + "empty.hdr"); }, {dir + "empty.hdr"});
}

TEST(ImageIo, NanInfiniteAndNegativePixelsAreRefusedNamingThePixel) {
  const std::string dir = temp_dir();
  EnvMap map = make_latlong(16, 8);
  fill_random(map, 7);
  EnvMap nan = map, inf = map, neg = map;
  nan.pixel(2 * 16 + 3)[1] = std::numeric_limits<float>::quiet_NaN();
  inf.pixel(5 * 16 + 11)[0] = std::numeric_limits<float>::infinity();
  neg.pixel(7 * 16 + 0)[2] = -0.25f;
  write_envmap(dir + "nan.pfm", nan);
  write_envmap(dir + "inf.exr", inf);
  write_envmap(dir + "neg.exr", neg);
  expect_input_error([&] { read_envmap(dir + "nan.pfm"); }, {dir + "nan.pfm: pixel (3, 2) is NaN"});
  expect_input_error([&] { read_envmap(dir + "inf.exr"); }, {dir + "inf.exr: pixel (11, 5) is infinite"});
  expect_input_error([&] { read_envmap(dir + "neg.exr"); }, {dir + "neg.exr: pixel (0, 7) is negative"});
  // Asked not to check, the values come through untouched.
  EXPECT_TRUE(std::isnan(read_envmap(dir + "nan.pfm", {.layout = std::nullopt, .reject_bad_pixels = false}).pixel(2 * 16 + 3)[1]));
  EXPECT_EQ(read_envmap(dir + "neg.exr", {.layout = std::nullopt, .reject_bad_pixels = false}).pixel(7 * 16)[2], -0.25f);
  // RGBE cannot hold them at all.
  expect_input_error([&] { write_envmap(dir + "neg.hdr", neg); }, {dir + "neg.hdr", "negative"});
  EXPECT_FALSE(fs::exists(dir + "neg.hdr"));
}

// Real probes carry slight negatives (out-of-gamut colours, noise below black, a lossy
// codec's ringing copied into a lossless file): with someone to warn they are read as 0 and
// said so in one line; a map whose negatives hold more than 1 % of a channel's power is not
// radiance and stays refused, as does any negative where nobody would hear of it.
TEST(ImageIo, SlightNegativesAreReadAsZeroWithOneWarningWhereSomeoneHearsIt) {
  const std::string dir = temp_dir();
  EnvMap map = make_latlong(64, 32);
  for (float& v : map.rgb) v = 1.0f;
  EnvMap slight = map, strong = map, with_nan = map;
  slight.pixel(3 * 64 + 5)[0] = -0.25f;  // one pixel of 2048, near the pole: ~1e-4 of R's power
  slight.pixel(16 * 64 + 9)[1] = -1e-6f;
  slight.pixel(16 * 64 + 9)[2] = -2e-6f;
  for (size_t i = 0; i < 40; ++i) strong.pixel(16 * 64 + i)[2] = -1.0f;  // ~2 % of B's power
  with_nan.pixel(3 * 64 + 5)[0] = -0.25f;
  with_nan.pixel(20 * 64 + 1)[2] = std::numeric_limits<float>::quiet_NaN();
  write_envmap(dir + "slight.exr", slight);
  write_envmap(dir + "strong.exr", strong);
  write_envmap(dir + "nan.pfm", with_nan);

  // Nobody to tell: refused, as before.
  expect_input_error([&] { read_envmap(dir + "slight.exr"); }, {dir + "slight.exr: pixel (5, 3) is negative"});

  std::vector<std::string> warnings;
  const WarningSink before = set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const EnvMap read = read_envmap(dir + "slight.exr");
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find(dir + "slight.exr: 2 pixels with negative values (lowest -0.25"), std::string::npos)
      << warnings[0];
  EXPECT_EQ(read.pixel(3 * 64 + 5)[0], 0.0f);
  EXPECT_EQ(read.pixel(16 * 64 + 9)[1], 0.0f);
  EXPECT_EQ(read.pixel(16 * 64 + 9)[2], 0.0f);
  EXPECT_EQ(read.pixel(3 * 64 + 5)[1], 1.0f);  // the rest untouched
  const NegativeValues measured = find_negative_values(slight);
  EXPECT_EQ(measured.count, 2u);
  EXPECT_EQ(measured.lowest, -0.25f);
  // R: 0.25 dw(row 3) against 4 pi - dw(row 3) of ones (the pixel itself holds none).
  const double dw3 = pixel_solid_angle(slight, 3 * 64 + 5);
  EXPECT_NEAR(measured.share, 0.25 * dw3 / (4 * M_PI - dw3), 1e-9);

  warnings.clear();
  expect_input_error([&] { read_envmap(dir + "strong.exr"); },
                     {dir + "strong.exr: 40 pixels with negative values (lowest -1) hold", "not radiance"});
  // A NaN is named even when the negatives before it would pass.
  expect_input_error([&] { read_envmap(dir + "nan.pfm"); }, {dir + "nan.pfm: pixel (1, 20) is NaN"});
  EXPECT_TRUE(warnings.empty());
  set_warning_sink(before);
}

// A DWA file's codec ringing (tiny negatives around a bright spot) is clamped without a word;
// a DWA file resized with a sharp filter rang far more (7 % of a channel's power below zero:
// an audit's oiiotool --resize of a Blender studio light) and was clamped alike, exit 0, while
// the same pixels in ZIP are refused. Beyond a codec's ringing it is refused too.
TEST(ImageIo, ADwaFileRingingBeyondItsCodecIsRefusedAsZipWouldBe) {
  const std::string dir = temp_dir();
  auto write_dwa = [&](const std::string& name, float ring) {
    Imf::Header header(64, 32);
    header.compression() = Imf::DWAA_COMPRESSION;
    for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    std::vector<float> rgb(3 * 64 * 32, 1.0f);
    for (int x = 0; x < 64; ++x)
      for (int c = 0; c < 3; ++c) rgb[3 * (size_t(8) * 64 + size_t(x)) + size_t(c)] = ring;  // a ringing row
    Imf::FrameBuffer fb;
    for (int c = 0; c < 3; ++c)
      fb.insert(std::string(1, "RGB"[c]), Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&rgb[size_t(c)]), 12, 12 * 64));
    Imf::OutputFile file((dir + name).c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(32);
  };
  write_dwa("slight.exr", -0.001f);  // 0.003 % of the power: a codec's ringing
  write_dwa("strong.exr", -2.0f);   // 6 % below zero: not radiance
  const WarningSink before = set_warning_sink([](const std::string&) {});
  const EnvMap slight = read_envmap(dir + "slight.exr");
  EXPECT_GE(*std::min_element(slight.rgb.begin(), slight.rgb.end()), 0.0f);
  expect_input_error([&] { read_envmap(dir + "strong.exr"); }, {dir + "strong.exr:", "not radiance"});
  set_warning_sink(before);
}

// An EXR of channels X, Y and Z is CIE XYZ: it was read as grey from Y, X and Z dropped.
TEST(ImageIo, AnXyzExrIsConvertedToRec709) {
  const std::string dir = temp_dir();
  Imf::Header header(8, 4);
  for (const char* c : {"X", "Y", "Z"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
  // Rec. 709 red, green and blue at 1 and a grey, in XYZ (D65, the sRGB matrix).
  const double xyz[4][3] = {{0.4124564, 0.2126729, 0.0193339}, {0.3575761, 0.7151522, 0.1191920},
                            {0.1804375, 0.0721750, 0.9503041}, {0.9505, 1.0, 1.089}};
  std::vector<float> px(3 * 8 * 4);
  for (size_t i = 0; i < 32; ++i)
    for (int c = 0; c < 3; ++c) px[3 * i + size_t(c)] = float(xyz[i % 4][c]);
  Imf::FrameBuffer fb;
  for (int c = 0; c < 3; ++c)
    fb.insert(std::string(1, "XYZ"[c]), Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&px[size_t(c)]), 12, 12 * 8));
  {
    Imf::OutputFile file((dir + "xyz.exr").c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(4);
  }
  ReadMapOptions latlong;
  latlong.layout = Layout::Hemisphere;
  const WarningSink before = set_warning_sink([](const std::string&) {});
  const EnvMap m = read_envmap(dir + "xyz.exr", latlong);
  set_warning_sink(before);
  const double rgb[4][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  for (size_t i = 0; i < 4; ++i)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(m.pixel(i)[c], rgb[i][c], 2e-3) << "pixel " << i << " channel " << c;
}

// An EXR's image is its display window (OpenEXR, OpenImageIO, Nuke): a data window that is
// offset, cropped or larger than it places the stored pixels inside it. Pixels of the display
// window without data are masked, not black; data outside it is dropped.
void write_windowed_exr(const std::string& path, Imath::Box2i display, Imath::Box2i data) {
  Imf::Header header(display, data);
  for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
  const int w = data.max.x - data.min.x + 1, h = data.max.y - data.min.y + 1;
  std::vector<float> rgb(3 * size_t(w) * size_t(h));
  for (int y = 0; y < h; ++y)  // each pixel holds its own display coordinates: x + 1, y + 1, 7
    for (int x = 0; x < w; ++x) {
      float* p = &rgb[3 * (size_t(y) * size_t(w) + size_t(x))];
      p[0] = float(x + data.min.x + 1), p[1] = float(y + data.min.y + 1), p[2] = 7;
    }
  Imf::FrameBuffer fb;
  const size_t xs = 3 * sizeof(float), ys = xs * size_t(w);
  for (int c = 0; c < 3; ++c)
    fb.insert(std::string(1, "RGB"[c]), Imf::Slice::Make(Imf::FLOAT, &rgb[size_t(c)], data, xs, ys));
  Imf::OutputFile file(path.c_str(), header);
  file.setFrameBuffer(fb);
  file.writePixels(h);
}

TEST(ImageIo, AnExrIsItsDisplayWindowWithPixelsWithoutDataMasked) {
  const std::string dir = temp_dir();
  const Imath::Box2i display({0, 0}, {31, 15});
  // Offset and cropped: rows 4..15 and columns 3..33 stored (two beyond the right edge).
  write_windowed_exr(dir + "crop.exr", display, Imath::Box2i({3, 4}, {33, 15}));
  const EnvMap crop = read_envmap(dir + "crop.exr");
  ASSERT_EQ(crop.layout, Layout::LatLong);
  ASSERT_EQ(crop.width, 32);
  ASSERT_EQ(crop.height, 16);
  ASSERT_EQ(crop.valid.size(), crop.pixel_count());
  for (int y = 0; y < 16; ++y)
    for (int x = 0; x < 32; ++x) {
      const size_t i = size_t(y) * 32 + size_t(x);
      const bool stored = x >= 3 && y >= 4;
      EXPECT_EQ(crop.is_valid(i), stored) << x << ", " << y;
      if (stored) {
        EXPECT_EQ(crop.pixel(i)[0], float(x + 1));
        EXPECT_EQ(crop.pixel(i)[1], float(y + 1));
      }
    }
  // Overscan: every pixel of the display window stored, the rest dropped; nothing masked.
  write_windowed_exr(dir + "over.exr", display, Imath::Box2i({-2, -1}, {35, 17}));
  const EnvMap over = read_envmap(dir + "over.exr");
  ASSERT_EQ(over.width, 32);
  EXPECT_TRUE(over.valid.empty());
  EXPECT_EQ(over.pixel(0)[0], 1.0f);
  EXPECT_EQ(over.pixel(31 + 15 * 32)[1], 16.0f);
  // A display window far larger than the data stored (a few bytes claiming a huge image) is
  // refused before anything of its size is allocated.
  write_windowed_exr(dir + "huge.exr", Imath::Box2i({0, 0}, {8191, 4095}), Imath::Box2i({0, 0}, {1, 0}));
  expect_input_error([&] { read_envmap(dir + "huge.exr"); }, {dir + "huge.exr: the display window 8192x4096 is more than 4 times"});
  // Nothing inside the display window: refused.
  write_windowed_exr(dir + "out.exr", display, Imath::Box2i({40, 0}, {45, 15}));
  expect_input_error([&] { read_envmap(dir + "out.exr"); }, {dir + "out.exr", "lies outside the display window"});
}

// OpenEXR's whiteLuminance (cd/m2 of RGB 1, 1, 1) makes a file absolute: read as radiance
// (683 Y = cd/m2), scaled by W / 683; it was read as relative. Our radiance maps carry it, so
// that every OpenEXR reader knows their luminance; a wrong one is refused.
TEST(ImageIo, AnExrsWhiteLuminanceMakesItRadianceAndOursCarryIt) {
  const std::string dir = temp_dir();
  auto write = [&](const std::string& name, float white) {
    Imf::Header header(4, 2);
    for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    Imf::addWhiteLuminance(header, white);
    std::vector<float> rgb(24, 1.0f);
    rgb[3] = 2.0f;  // pixel 1's red
    Imf::FrameBuffer fb;
    for (int c = 0; c < 3; ++c)
      fb.insert(std::string(1, "RGB"[c]), Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&rgb[size_t(c)]), 12, 48));
    Imf::OutputFile file((dir + name).c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(2);
    return dir + name;
  };
  const EnvMap nits = read_envmap(write("nits.exr", 100.0f));
  EXPECT_EQ(nits.units, Units::Radiance);
  EXPECT_FLOAT_EQ(nits.pixel(0)[1], float(100.0 / 683.0));
  EXPECT_FLOAT_EQ(nits.pixel(1)[0], float(200.0 / 683.0));
  EXPECT_NEAR(683.0 * luminance(nits.pixel(0)[0], nits.pixel(0)[1], nits.pixel(0)[2]), 100.0, 1e-4);
  expect_input_error([&] { read_envmap(write("zero.exr", 0.0f)); }, {dir + "zero.exr", "whiteLuminance 0"});
  // Ours: radiance maps state 683, relative ones nothing; both read back as written.
  EnvMap map = make_latlong(4, 2);
  for (float& v : map.rgb) v = 0.5f;
  map.units = Units::Radiance;
  write_envmap(dir + "radiance.exr", map);
  {
    Imf::InputFile in((dir + "radiance.exr").c_str());
    ASSERT_TRUE(Imf::hasWhiteLuminance(in.header()));
    EXPECT_FLOAT_EQ(Imf::whiteLuminance(in.header()), 683.0f);
  }
  const EnvMap back = read_envmap(dir + "radiance.exr");
  EXPECT_EQ(back.units, Units::Radiance);
  EXPECT_EQ(back.rgb, map.rgb) << "our units attribute decides: not scaled twice";
  map.units = Units::Relative;
  write_envmap(dir + "relative.exr", map);
  Imf::InputFile in((dir + "relative.exr").c_str());
  EXPECT_FALSE(Imf::hasWhiteLuminance(in.header()));
}

// Files in other primaries are converted to Rec. 709 (core/chromaticities.h): an EXR whose
// chromaticities attribute is ACES AP0, a Radiance file with a PRIMARIES line. The ACES white
// stays white, a pure AP0 red becomes the first column of the published matrix.
TEST(ImageIo, FilesInOtherPrimariesAreConvertedToRec709) {
  const std::string dir = temp_dir();
  const Imf::Chromaticities ap0({0.7347f, 0.2653f}, {0.0f, 1.0f}, {0.0001f, -0.0770f}, {0.32168f, 0.33767f});
  Imf::Header header(4, 2);
  for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
  Imf::addChromaticities(header, ap0);
  std::vector<float> rgb{1, 1, 1, 1, 0, 0, 0.5f, 0.5f, 0.5f, 0, 0, 0, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1, 1};
  Imf::FrameBuffer fb;
  for (int c = 0; c < 3; ++c)
    fb.insert(std::string(1, "RGB"[c]), Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&rgb[size_t(c)]), 12, 48));
  {
    Imf::OutputFile file((dir + "aces.exr").c_str(), header);
    file.setFrameBuffer(fb);
    file.writePixels(2);
  }
  // Read without the negative check: AP0's red lies far outside Rec. 709's gamut.
  const EnvMap aces = read_envmap(dir + "aces.exr", {.layout = Layout::LatLong, .reject_bad_pixels = false});
  const auto m = to_rec709_matrix(Chromaticities{{0.7347, 0.2653}, {0.0, 1.0}, {0.0001, -0.0770}, {0.32168, 0.33767}}, "");
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(aces.pixel(0)[c], 1.0f, 1e-5) << c;  // white stays white
  EXPECT_NEAR(aces.pixel(1)[0], 2.52168619f, 1e-5);                              // AP0 red: the first column
  EXPECT_NEAR(aces.pixel(1)[1], m[3], 1e-6);
  EXPECT_NEAR(aces.pixel(1)[2], m[6], 1e-6);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(aces.pixel(2)[c], 0.5f, 1e-5) << c;
  // With the negative check, that red is more than 1 % of a channel's power: refused.
  expect_input_error([&] { read_envmap(dir + "aces.exr", {.layout = Layout::LatLong}); },
                     {dir + "aces.exr: pixel (1, 0) is negative"});
  // A Radiance file with the same primaries: the same conversion; with Rec. 709's, none.
  EnvMap grey = make_latlong(4, 2);
  for (float& v : grey.rgb) v = 0.25f;
  grey.pixel(5)[0] = 1.0f, grey.pixel(5)[1] = 0.0f, grey.pixel(5)[2] = 0.0f;
  write_envmap(dir + "plain.hdr", grey);
  std::string bytes = read_bytes(dir + "plain.hdr");
  const std::string marker = "FORMAT=32-bit_rle_rgbe\n";
  ASSERT_NE(bytes.find(marker), std::string::npos);
  std::string with709 = bytes, withAp0 = bytes;
  with709.insert(bytes.find(marker), "PRIMARIES= 0.640 0.330 0.300 0.600 0.150 0.060 0.3127 0.3290\n");
  withAp0.insert(bytes.find(marker), "PRIMARIES= 0.7347 0.2653 0.0 1.0 0.0001 -0.0770 0.32168 0.33767\n");
  write_bytes(dir + "p709.hdr", with709);
  write_bytes(dir + "pap0.hdr", withAp0);
  EXPECT_EQ(read_envmap(dir + "p709.hdr").rgb, read_envmap(dir + "plain.hdr").rgb);
  const EnvMap hdr_ap0 = read_envmap(dir + "pap0.hdr", {.layout = std::nullopt, .reject_bad_pixels = false});
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(hdr_ap0.pixel(0)[c], 0.25f, 1e-5) << c;
  EXPECT_NEAR(hdr_ap0.pixel(5)[0], m[0], 1e-5);
  EXPECT_NEAR(hdr_ap0.pixel(5)[1], m[3], 1e-5);
  EXPECT_NEAR(hdr_ap0.pixel(5)[2], m[6], 1e-5);
  // Rec. 709 adapted to D50 (how Blender's studio lights state theirs, as ICC profiles do) is
  // Rec. 709: nothing converted.
  std::string with_d50 = bytes;
  with_d50.insert(bytes.find(marker), "PRIMARIES= 0.648447 0.330877 0.321187 0.597894 0.155901 0.0660563 0.345708 0.358541\n");
  write_bytes(dir + "pd50.hdr", with_d50);
  EXPECT_EQ(read_envmap(dir + "pd50.hdr").rgb, read_envmap(dir + "plain.hdr").rgb);
  write_bytes(dir + "bad.hdr", bytes.substr(0, bytes.find(marker)) + "PRIMARIES= 0.64 0.33\n" + bytes.substr(bytes.find(marker)));
  expect_input_error([&] { read_envmap(dir + "bad.hdr"); }, {dir + "bad.hdr", "bad PRIMARIES value"});
}

// PNGs are written and read by libpng in-process (core/picture_io.cpp, core/image_io.cpp).
// Its answers are held to OpenCV's codecs (the plugin): every 8- and 16-bit code written comes
// back exactly through OpenCV's decoder (16-bit PNG is big endian, OpenCV is BGR: either
// mix-up fails), and PNGs OpenCV encodes (grey, RGB, RGBA at 8 and 16 bits) and libpng
// encodes (a palette with transparency, interlaced) read as OpenCV's decoder reads them.
CameraImage camera_image_by_opencv(const std::string& bytes) {
  const cv::Mat img = lazy::decode_image(bytes);
  CameraImage out;
  out.width = img.cols, out.height = img.rows, out.bit_depth = img.depth() == CV_8U ? 8 : 16;
  const float s = out.bit_depth == 8 ? 1.0f / 255.0f : 1.0f / 65535.0f;
  const int ch = img.channels();
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < img.cols; ++x)
      for (int c = 0; c < 3; ++c) {
        const int k = x * ch + (ch == 1 ? 0 : 2 - c);
        out.rgb.push_back((out.bit_depth == 8 ? float(img.ptr<uint8_t>(y)[k]) : float(img.ptr<uint16_t>(y)[k])) * s);
      }
  return out;
}

std::string png_by_libpng(int width, int height, bool palette, bool interlaced) {
  std::string out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png_create_info_struct(png);
  png_set_write_fn(png, &out, [](png_structp p, png_bytep d, png_size_t n) {
    static_cast<std::string*>(png_get_io_ptr(p))->append(reinterpret_cast<const char*>(d), n); }, nullptr);
  png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), 8, palette ? PNG_COLOR_TYPE_PALETTE : PNG_COLOR_TYPE_RGB,
               interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  std::vector<png_color> colours;
  for (int i = 0; i < 16; ++i) colours.push_back({png_byte(i * 16), png_byte(255 - i * 9), png_byte(i * i)});
  std::vector<png_byte> alpha(16, 128);
  if (palette) {
    png_set_PLTE(png, info, colours.data(), 16);
    png_set_tRNS(png, info, alpha.data(), 16, nullptr);
  }
  std::vector<png_byte> pixels(size_t(width) * size_t(height) * (palette ? 1 : 3));
  for (size_t i = 0; i < pixels.size(); ++i) pixels[i] = png_byte(palette ? (i * 7) % 16 : (i * 31) % 256);
  std::vector<png_bytep> rows;
  for (int y = 0; y < height; ++y) rows.push_back(pixels.data() + size_t(y) * size_t(width) * (palette ? 1 : 3));
  png_set_rows(png, info, rows.data());
  png_write_png(png, info, PNG_TRANSFORM_IDENTITY, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

TEST(ImageIo, PngsReadAndWriteAsOpenCvsCodecsDo) {
  const std::string dir = temp_dir();
  for (const int depth : {8, 16}) {
    RgbImage img;
    img.width = 37, img.height = 5;
    const double max = depth == 8 ? 255.0 : 65535.0;
    for (int i = 0; i < 3 * 37 * 5; ++i) img.rgb.push_back(float(((i * 7919) % int(max + 1)) / max));
    const std::string path = dir + "codes" + std::to_string(depth) + ".png";
    write_code_image(path, img, depth);
    const CameraImage back = camera_image_by_opencv(read_bytes(path));
    ASSERT_EQ(back.bit_depth, depth);
    ASSERT_EQ(back.width, 37);
    ASSERT_EQ(back.height, 5);
    for (size_t i = 0; i < img.rgb.size(); ++i)
      ASSERT_EQ(std::lround(back.rgb[i] * max), std::lround(img.rgb[i] * max)) << depth << " bit, value " << i;
  }
  std::vector<std::pair<std::string, std::string>> files;  // name, bytes
  for (const int type : {CV_8UC1, CV_16UC1, CV_8UC3, CV_16UC3, CV_8UC4, CV_16UC4}) {
    cv::Mat m(6, 9, type);
    cv::randu(m, 0, CV_MAT_DEPTH(type) == CV_8U ? 256 : 65536);
    std::vector<uint8_t> bytes;
    ASSERT_TRUE(lazy::encode_image(".png", m, {}, bytes));
    files.push_back({"opencv_" + std::to_string(type) + ".png", std::string(bytes.begin(), bytes.end())});
  }
  files.push_back({"palette.png", png_by_libpng(11, 7, true, false)});
  files.push_back({"interlaced.png", png_by_libpng(13, 9, false, true)});
  for (const auto& [name, bytes] : files) {
    SCOPED_TRACE(name);
    write_bytes(dir + name, bytes);
    const CameraImage ours = read_camera_image(dir + name), peer = camera_image_by_opencv(bytes);
    EXPECT_EQ(ours.bit_depth, peer.bit_depth);
    EXPECT_EQ(ours.width, peer.width);
    EXPECT_EQ(ours.height, peer.height);
    EXPECT_EQ(ours.rgb, peer.rgb);
  }
  // Damaged: the pixel data cut short is refused in one line, not a crash.
  const std::string cut = files[3].second.substr(0, files[3].second.size() - 40);
  write_bytes(dir + "cut.png", cut);
  expect_input_error([&] { read_camera_image(dir + "cut.png"); }, {dir + "cut.png"});
}

// JPEGs are decoded by libjpeg-turbo in-process too: the same pixels as OpenCV's decoder
// gives (IMREAD_UNCHANGED) on files OpenCV encodes (colour, grey, progressive) and on real
// camera files of the shared sets (an iPhone photo, calibration shots). CMYK is left to it.
TEST(ImageIo, JpegsReadAsOpenCvsDecoderReadsThem) {
  const std::string dir = temp_dir();
  std::vector<std::pair<std::string, std::string>> files;
  cv::Mat colour(48, 64, CV_8UC3), grey(31, 17, CV_8UC1);
  cv::randu(colour, 0, 256);
  cv::randu(grey, 0, 256);
  for (const auto& [name, mat, params] :
       std::vector<std::tuple<std::string, cv::Mat, std::vector<int>>>{
           {"colour.jpg", colour, {}},
           {"grey.jpg", grey, {}},
           {"progressive.jpg", colour, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}},
           {"q100.jpg", colour, {cv::IMWRITE_JPEG_QUALITY, 100}}}) {
    std::vector<uint8_t> bytes;
    ASSERT_TRUE(lazy::encode_image(".jpg", mat, params, bytes));
    files.push_back({name, std::string(bytes.begin(), bytes.end())});
  }
  for (const std::string real : {"/hdr-mirrorball-kartik/ball_1-40s.jpg", "/calib-opencv-stereo-9x6/left01.jpg",
                                 "/calib-ocamcalib-fisheye1/Fisheye1_1.jpg"})
    if (fs::exists(kData + real)) files.push_back({fs::path(real).filename().string(), read_bytes(kData + real)});
  ASSERT_GE(files.size(), 5u);
  for (const auto& [name, bytes] : files) {
    SCOPED_TRACE(name);
    write_bytes(dir + name, bytes);
    const CameraImage ours = read_camera_image(dir + name), peer = camera_image_by_opencv(bytes);
    EXPECT_EQ(ours.bit_depth, 8);
    EXPECT_EQ(ours.width, peer.width);
    EXPECT_EQ(ours.height, peer.height);
    EXPECT_TRUE(ours.rgb == peer.rgb);
  }
}

// A TIFF's own Orientation tag turns it as a JPEG's EXIF does: an uncompressed 3x2 RGB
// TIFF with distinct pixels, shown in each of the eight orientations. Expected: where each
// of the stored image's four corners is shown (the EXIF specification's table), and the
// turned size. Without a tag, or with an invalid one (0, 9), the pixels are read as stored.
TEST(ImageIo, TiffsAreTurnedAsTheirOrientationTagSays) {
  const std::string dir = temp_dir();
  auto tiff = [](int orientation) {
    std::string t;
    auto u16 = [&](uint32_t v) { t += char(v & 0xff), t += char(v >> 8); };
    auto u32 = [&](uint32_t v) { u16(v & 0xffff), u16(v >> 16); };
    const int entries = orientation < 0 ? 9 : 10;
    const uint32_t bits = 8 + 2 + 12 * uint32_t(entries) + 4, strip = bits + 6;
    t += "II", u16(42), u32(8), u16(uint32_t(entries));
    auto entry = [&](uint32_t tag, uint32_t type, uint32_t count, uint32_t value) {
      u16(tag), u16(type), u32(count);
      type == 3 && count == 1 ? (u16(value), u16(0)) : u32(value);
    };
    entry(256, 3, 1, 3), entry(257, 3, 1, 2), entry(258, 3, 3, bits), entry(259, 3, 1, 1), entry(262, 3, 1, 2);
    entry(273, 4, 1, strip);
    if (orientation >= 0) entry(274, 3, 1, uint32_t(orientation));
    entry(277, 3, 1, 3), entry(278, 3, 1, 2), entry(279, 4, 1, 18);
    u32(0), u16(8), u16(8), u16(8);
    for (int i = 0; i < 6; ++i) t += char(40 * i + 1), t += char(40 * i + 2), t += char(40 * i + 3);  // pixel i: 40 i + 1..3
    return t;
  };
  // Stored: pixel i of row-major order, its red code 40 i + 1. Corners (x, y) of the 3x2 image.
  auto red = [](int x, int y) { return float(40 * (3 * y + x) + 1) / 255.0f; };
  const int shown_top_left[9][2] = {{0, 0}, {0, 0}, {2, 0}, {2, 1}, {0, 1}, {0, 0}, {0, 1}, {2, 1}, {2, 0}};
  for (int o = -1; o <= 9; ++o) {
    SCOPED_TRACE(o);
    write_bytes(dir + "t.tif", tiff(o));
    const CameraImage img = read_camera_image(dir + "t.tif");
    const int turned = o >= 5 && o <= 8 ? o : 0;
    ASSERT_EQ(img.width, turned ? 2 : 3);
    ASSERT_EQ(img.height, turned ? 3 : 2);
    const int k = o >= 1 && o <= 8 ? o : 1;
    const int x0 = shown_top_left[k][0], y0 = shown_top_left[k][1];
    EXPECT_FLOAT_EQ(img.rgb[0], red(x0, y0));
    // The shown bottom right is the stored corner opposite the shown top left.
    EXPECT_FLOAT_EQ(img.rgb[3 * size_t(img.width * img.height - 1)], red(2 - x0, 1 - y0));
    // The shown top right: along the stored row for 1-4, along the stored column for 5-8.
    const float top_right = img.rgb[3 * size_t(img.width - 1)];
    if (k <= 4)
      EXPECT_FLOAT_EQ(top_right, red(2 - x0, y0));
    else
      EXPECT_FLOAT_EQ(top_right, red(x0, 1 - y0));
    // Read as stored (a fisheye's sensor frame), the TIFF that OpenCV turned is turned back.
    const CameraImage stored = read_camera_image(dir + "t.tif", true);
    ASSERT_EQ(stored.width, 3);
    ASSERT_EQ(stored.height, 2);
    for (int i = 0; i < 6; ++i) EXPECT_FLOAT_EQ(stored.rgb[3 * size_t(i)], red(i % 3, i / 3)) << i;
    // Every shown pixel is the stored one stored_from_shown names, and shown_from_stored
    // takes it back (what turns a calibration view's corners between frames).
    for (int y = 0; y < img.height; ++y)
      for (int x = 0; x < img.width; ++x) {
        const std::array<double, 2> s = stored_from_shown(k, 3, 2, {double(x), double(y)});
        EXPECT_FLOAT_EQ(img.rgb[3 * size_t(y * img.width + x)], red(int(s[0]), int(s[1])));
        const std::array<double, 2> back = shown_from_stored(k, 3, 2, s);
        EXPECT_EQ(back[0], x);
        EXPECT_EQ(back[1], y);
      }
  }
}

// Panorama stitchers (PTGui, Hugin) write HDR panoramas as floating-point TIFFs: 32-bit IEEE
// floats are read exactly (RGBA: alpha is the mask, as in an EXR); LogLuv (what OpenCV
// writes for 3-channel floats, and Radiance's tools) to its 0.3 % steps in luminance. An
// integer TIFF holds camera codes and is refused as a map; as a probe photo it stays codes.
TEST(ImageIo, FloatingPointTiffsAreMapsAndIntegerOnesAreNot) {
  const std::string dir = temp_dir();
  cv::Mat rgba(8, 16, CV_32FC4), rgb(8, 16, CV_32FC3), codes(8, 16, CV_16UC3);
  cv::randu(rgba, 0.1f, 4.0f);
  cv::randu(rgb, 0.1f, 4.0f);
  cv::randu(codes, 0, 65535);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) rgba.at<cv::Vec4f>(y, x)[3] = y == 0 ? 0.0f : 1.0f;  // the top row transparent
  for (const auto& [name, mat] : std::vector<std::pair<std::string, cv::Mat>>{{"rgba.tif", rgba}, {"rgb.tif", rgb},
                                                                              {"codes.tif", codes}}) {
    std::vector<uint8_t> bytes;
    ASSERT_TRUE(lazy::encode_image(".tif", mat, {}, bytes));
    write_bytes(dir + name, std::string(bytes.begin(), bytes.end()));
  }
  const EnvMap a = read_envmap(dir + "rgba.tif");
  ASSERT_EQ(a.width, 16);
  ASSERT_EQ(a.valid.size(), 128u);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) {
      const size_t i = size_t(y * 16 + x);
      EXPECT_EQ(a.is_valid(i), y > 0);
      for (int c = 0; c < 3; ++c) ASSERT_EQ(a.rgb[3 * i + size_t(c)], rgba.at<cv::Vec4f>(y, x)[2 - c]);
    }
  const EnvMap b = read_envmap(dir + "rgb.tif");  // LogLuv: through XYZ, 16-bit log luminance
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 16; ++x) {
      const float* p = b.pixel(size_t(y * 16 + x));
      const cv::Vec3f q = rgb.at<cv::Vec3f>(y, x);
      const double ours = luminance(p[0], p[1], p[2]), truth = luminance(q[2], q[1], q[0]);
      ASSERT_NEAR(ours / truth, 1.0, 0.01) << x << "," << y;
    }
  expect_input_error([&] { read_envmap(dir + "codes.tif"); }, {dir + "codes.tif", "integer samples are camera codes"});
  EXPECT_EQ(read_rgb_image(dir + "rgba.tif").code_bits, 0);
  EXPECT_EQ(read_rgb_image(dir + "codes.tif").code_bits, 16);
}

// A PNG's eXIf chunk (before the image data) turns it as a JPEG's EXIF does, as browsers
// show it: a 3x2 PNG with Orientation 6 reads 2x3, the stored bottom-left pixel top left.
TEST(ImageIo, APngsExifChunkTurnsItToo) {
  const std::string dir = temp_dir();
  RgbImage img;
  img.width = 3, img.height = 2;
  for (int i = 0; i < 6; ++i)
    for (int c = 0; c < 3; ++c) img.rgb.push_back(float(40 * i + 1) / 255.0f);
  write_code_image(dir + "plain.png", img, 8);
  const std::string png = read_bytes(dir + "plain.png");
  std::string tiff = std::string("MM\0*\0\0\0\x08", 8) + std::string("\0\x01", 2) +
                     std::string("\x01\x12\0\x03\0\0\0\x01\0\x06\0\0", 12) + std::string(4, '\0');
  const std::string type_and_data = "eXIf" + tiff;
  const uint32_t crc = uint32_t(crc32(0, reinterpret_cast<const Bytef*>(type_and_data.data()), uInt(type_and_data.size())));
  auto be32 = [](uint32_t v) { return std::string{char(v >> 24), char((v >> 16) & 0xff), char((v >> 8) & 0xff), char(v & 0xff)}; };
  const std::string chunk = be32(uint32_t(tiff.size())) + type_and_data + be32(crc);
  write_bytes(dir + "turned.png", png.substr(0, 33) + chunk + png.substr(33));  // after IHDR (8 + 25 bytes)
  const CameraImage turned = read_camera_image(dir + "turned.png");
  ASSERT_EQ(turned.width, 2);
  ASSERT_EQ(turned.height, 3);
  EXPECT_FLOAT_EQ(turned.rgb[0], float(40 * 3 + 1) / 255.0f);  // stored (0, 1)
  EXPECT_FLOAT_EQ(turned.rgb[3], float(40 * 0 + 1) / 255.0f);  // stored (0, 0)
  EXPECT_EQ(read_camera_image(dir + "plain.png").width, 3);
}

TEST(ImageIo, MasksCannotBeWrittenToFormatsWithoutAlpha) {
  const std::string dir = temp_dir();
  EnvMap map = make_latlong(16, 8);
  map.valid.assign(map.pixel_count(), 1);
  map.valid[3] = 0;
  expect_input_error([&] { write_envmap(dir + "m.hdr", map); }, {dir + "m.hdr", "mask"});
  expect_input_error([&] { write_envmap(dir + "m.pfm", map); }, {dir + "m.pfm", "mask"});
  EXPECT_TRUE(fs::is_empty(dir));
}

TEST(ImageIo, UnknownExtensionsAreRefused) {
  const std::string dir = temp_dir();
  write_bytes(dir + "m.tga", "whatever");
  expect_input_error([&] { read_envmap(dir + "m.tga"); }, {dir + "m.tga", "unsupported map format"});
  expect_input_error([&] { write_envmap(dir + "m.png", make_latlong(4, 2)); }, {dir + "m.png", "unsupported"});
  expect_input_error([&] { read_envmap(dir + "missing.exr"); }, {dir + "missing.exr", "cannot open"});
  EXPECT_FALSE(fs::exists(dir + "m.png"));
}

TEST(ImageIo, UnwritablePathsAreRefusedAndLeaveNoFileBehind) {
  const std::string dir = temp_dir();
  const EnvMap map = make_latlong(8, 4);
  expect_input_error([&] { write_envmap(dir + "no/such/dir/x.exr", map); },
                     {dir + "no/such/dir/x.exr: cannot write: No such file or directory"});
  write_bytes(dir + "file", "x");
  expect_input_error([&] { write_envmap(dir + "file/x.hdr", map); }, {dir + "file/x.hdr: cannot write:"});
  // The target is a directory: the temporary file is written, the rename fails, and the
  // temporary is removed.
  fs::create_directory(dir + "taken.exr");
  expect_input_error([&] { write_envmap(dir + "taken.exr", map); }, {dir + "taken.exr: cannot write:"});
  expect_input_error([&] { write_file_atomically(dir + "taken.exr", "{}"); }, {dir + "taken.exr: cannot write:"});
  expect_input_error([&] { write_display_image(dir + "nodir/x.png", 1, 1, {0, 0, 0}); }, {dir + "nodir/x.png: cannot write"});
  EXPECT_EQ(count_temp_files(dir), 0u);
  EXPECT_TRUE(fs::is_empty(dir + "taken.exr"));
}

TEST(ImageIo, WriteFileAtomicallyReplacesTheWholeFile) {
  const std::string dir = temp_dir();
  write_file_atomically(dir + "a.json", std::string(1000, 'x'));
  write_file_atomically(dir + "a.json", "{\"ok\": true}\n");
  EXPECT_EQ(read_bytes(dir + "a.json"), "{\"ok\": true}\n");
  EXPECT_EQ(count_temp_files(dir), 0u);
}

// ----------------------------------------------------------------------------- camera images

TEST(ImageIo, CameraImagesAreScaledByTheirBitDepthAndTurnedToRgb) {
  const std::string dir = temp_dir();
  // Binary PPM/PGM made by hand: 8-bit colour, 16-bit colour (big-endian), 8-bit grey.
  write_bytes(dir + "c8.ppm", std::string("P6\n2 1\n255\n") + std::string("\xff\x00\x00\x00\x80\xff", 6));
  const CameraImage c8 = read_camera_image(dir + "c8.ppm");
  EXPECT_EQ(c8.width, 2);
  EXPECT_EQ(c8.height, 1);
  EXPECT_EQ(c8.bit_depth, 8);
  const std::vector<float> want8 = {1, 0, 0, 0, 128.0f / 255, 1};
  ASSERT_EQ(c8.rgb.size(), want8.size());
  for (size_t i = 0; i < want8.size(); ++i) EXPECT_FLOAT_EQ(c8.rgb[i], want8[i]) << i;

  write_bytes(dir + "c16.ppm", std::string("P6\n1 1\n65535\n") + std::string("\xff\xff\x80\x00\x00\x01", 6));
  const CameraImage c16 = read_camera_image(dir + "c16.ppm");
  EXPECT_EQ(c16.bit_depth, 16);
  EXPECT_FLOAT_EQ(c16.rgb[0], 1.0f);
  EXPECT_FLOAT_EQ(c16.rgb[1], 32768.0f / 65535);
  EXPECT_FLOAT_EQ(c16.rgb[2], 1.0f / 65535);

  write_bytes(dir + "g.pgm", std::string("P5\n1 1\n255\n\x33", 12));
  const CameraImage g = read_camera_image(dir + "g.pgm");
  EXPECT_FLOAT_EQ(g.rgb[0], 0.2f);
  EXPECT_FLOAT_EQ(g.rgb[2], 0.2f);
}

TEST(ImageIo, MemorialPhotographReadsAsAn8BitPortraitImage) {
  const CameraImage img = read_camera_image(kData + "/hdr-memorial-debevec/memorial0061.png");
  EXPECT_EQ(img.width, 512);
  EXPECT_EQ(img.height, 768);
  EXPECT_EQ(img.bit_depth, 8);
  ASSERT_EQ(img.rgb.size(), 512u * 768 * 3);
  EXPECT_TRUE(std::all_of(img.rgb.begin(), img.rgb.end(), [](float v) { return v >= 0 && v <= 1; }));
}

TEST(ImageIo, MissingOrUndecodableCameraImagesAreRefused) {
  const std::string dir = temp_dir();
  expect_input_error([&] { read_camera_image(dir + "none.png"); }, {dir + "none.png", "cannot open"});
  write_bytes(dir + "junk.png", "this is not a png");
  expect_input_error([&] { read_camera_image(dir + "junk.png"); }, {dir + "junk.png", "unsupported camera image format"});
}

TEST(ImageIo, DisplayImagesAreSrgbEncodedAndClamped) {
  const std::string dir = temp_dir();
  // sRGB code 128 is linear 0.21586 (IEC 61966-2-1); out-of-range values clamp.
  const std::vector<float> rgb = {0.0f, 0.21586f, 1.0f, -1.0f, 2.0f, 0.0031308f};
  write_display_image(dir + "d.png", 2, 1, rgb);
  const CameraImage back = read_camera_image(dir + "d.png");
  ASSERT_EQ(back.bit_depth, 8);
  const float want[6] = {0, 128, 255, 0, 255, 10};  // 12.92 * 0.0031308 * 255 = 10.3
  for (int i = 0; i < 6; ++i) EXPECT_FLOAT_EQ(back.rgb[i] * 255, want[i]) << i;
  write_display_image(dir + "d.jpg", 2, 1, rgb);
  EXPECT_EQ(read_camera_image(dir + "d.jpg").width, 2);
  expect_input_error([&] { write_display_image(dir + "d.bmp", 2, 1, rgb); }, {dir + "d.bmp", "unsupported"});
  EXPECT_EQ(count_temp_files(dir), 0u);
}

}  // namespace
}  // namespace lp

namespace lp {

namespace {
std::vector<std::string> shared_jpegs() {
  std::vector<std::string> out;
  if (!fs::exists(kData)) return out;
  for (const auto& e : fs::recursive_directory_iterator(kData))
    if (e.is_regular_file() && (e.path().extension() == ".jpg" || e.path().extension() == ".JPG"))
      out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

std::string file_bytes(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}
}  // namespace

// libjpeg decodes a JPEG cut short into a plausible image (the missing part grey) with only a
// warning; a truncated file must be refused by name instead, and a complete one never is.
TEST(ImageIo, TruncatedJpegIsRefusedAndCompleteOnesAreRead) {
  const auto jpegs = shared_jpegs();
  if (jpegs.empty()) GTEST_SKIP() << "no shared data";
  for (const auto& p : jpegs) EXPECT_NO_THROW(read_camera_image(p)) << p;  // every real JPEG we have
  const std::string dir = temp_dir();
  const std::string bytes = file_bytes(jpegs.front());
  for (double keep : {0.02, 0.3, 0.7, 0.999}) {
    const std::string cut = dir + "/cut.jpg";
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, size_t(keep * double(bytes.size())));
    try {
      read_camera_image(cut);
      ADD_FAILURE() << "a JPEG cut at " << keep << " was read";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("cut.jpg"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
    }
  }
  // Bytes appended after the end-of-image marker (some cameras add some) are not truncation.
  const std::string padded = dir + "/padded.jpg";
  std::ofstream(padded, std::ios::binary) << bytes << std::string(1000, '\xAB');
  const CameraImage a = read_camera_image(jpegs.front()), b = read_camera_image(padded);
  EXPECT_EQ(a.rgb, b.rgb);
}

}  // namespace lp
