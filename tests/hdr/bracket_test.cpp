#include "hdr/bracket.h"
#include "hdr/raw_input.h"
#include "tests/hdr/test_dng.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <unistd.h>

#include "core/chromaticities.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/warnings.h"
#include "hdr/merge.h"
#include "hdr/response.h"
#include "tests/core/icc_blob.h"
#include "tests/hdr/synthetic_bracket.h"

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;
namespace fs = std::filesystem;

struct TempDir {
  // One directory per test process: ctest runs these tests in parallel processes.
  fs::path path = fs::temp_directory_path() / ("lightprobe_hdr_bracket_test_" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() { fs::remove_all(path); }
  std::string png(const std::string& name, int w, int h) const {
    const std::string p = (path / name).string();
    write_display_image(p, w, h, std::vector<float>(3 * size_t(w) * size_t(h), 0.5f));
    return p;
  }
  std::string text(const std::string& name, const std::string& body) const {
    const std::string p = (path / name).string();
    std::ofstream(p) << body;
    return p;
  }
};

std::string message_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST(ReadExifExposure, GivesTheKartikMirrorBallPhotosTimesAndReadBracketRefusesTheirMixedCrops) {
  const std::string dir = kData + "/hdr-mirrorball-kartik/";
  EXPECT_DOUBLE_EQ(read_exif_exposure_seconds(dir + "ball_1-10s.jpg").value(), 0.1);
  EXPECT_DOUBLE_EQ(read_exif_exposure_seconds(dir + "ball_1-40s.jpg").value(), 1.0 / 40);
  EXPECT_DOUBLE_EQ(read_exif_exposure_seconds(dir + "ball_1-160s.jpg").value(), 1.0 / 160);
  EXPECT_EQ(read_exposure_list(dir + "exposures.csv"), (std::vector<double>{0.1, 1.0 / 40, 1.0 / 160}));
  // The three photos are hand crops of different sizes (480x472, 484x468, 490x480): not a
  // registered bracket, and the second file is the one named.
  const std::string msg = message_of([&] {
    read_bracket({dir + "ball_1-10s.jpg", dir + "ball_1-40s.jpg", dir + "ball_1-160s.jpg"});
  });
  EXPECT_EQ(msg, dir + "ball_1-40s.jpg: size 484x468 differs from the first image's 480x472");
  EXPECT_FALSE(read_exif_exposure_seconds(kData + "/hdr-memorial-debevec/memorial0061.png").has_value());
}

// A little-endian TIFF whose IFD0 points to an Exif IFD at offset 26, which the caller writes.
struct ExifTiff {
  std::string bytes;
  ExifTiff() {
    bytes += "II", u16(42), u32(8);
    u16(1), u16(0x8769), u16(4), u32(1), u32(26), u32(0);  // IFD0: the Exif IFD's offset
  }
  void u16(uint32_t v) { bytes += char(v & 0xff), bytes += char((v >> 8) & 0xff); }
  void u32(uint32_t v) { u16(v & 0xffff), u16(v >> 16); }
};

// The JPEG at `plain` with an APP1 Exif segment holding `tiff` spliced in after its
// start-of-image marker, written to tmp/name.
std::string write_with_exif(const TempDir& tmp, const std::string& name, const std::string& plain, const ExifTiff& tiff) {
  std::ifstream in(plain, std::ios::binary);
  const std::string jpeg((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string app1 = std::string("Exif\0\0", 6) + tiff.bytes;
  const size_t length = app1.size() + 2;
  const std::string path = (tmp.path / name).string();
  std::ofstream(path, std::ios::binary) << jpeg.substr(0, 2) << char(0xFF) << char(0xE1) << char(length >> 8)
                                        << char(length & 0xff) << app1 << jpeg.substr(2);
  return path;
}

// A JPEG whose EXIF holds one ExposureTime entry of the given TIFF type and values (little
// endian, in an Exif IFD), spliced in after the JPEG's start-of-image marker.
std::string jpeg_with_exposure_entry(const TempDir& tmp, const std::string& name, uint16_t type,
                                     std::vector<uint32_t> values) {
  ExifTiff t;
  const uint32_t count = type == 5 ? uint32_t(values.size() / 2) : uint32_t(values.size());
  t.u16(1), t.u16(0x829A), t.u16(type), t.u32(count), t.u32(44), t.u32(0);  // Exif IFD: ExposureTime
  for (uint32_t v : values) t.u32(v);
  return write_with_exif(tmp, name, tmp.png(name + ".plain.jpg", 8, 6), t);
}

TEST(ReadExifExposure, AnExposureTimeOfTwoValuesIsRefusedNotReadAsItsFirst) {
  TempDir tmp;
  // One rational 1/8: 0.125 s.
  EXPECT_DOUBLE_EQ(read_exif_exposure_seconds(jpeg_with_exposure_entry(tmp, "good.jpg", 5, {1, 8})).value(), 0.125);
  // Two LONGs 1 and 8 (a writer that meant 1/8): the first alone would be 1 s.
  const std::string bad = jpeg_with_exposure_entry(tmp, "bad.jpg", 4, {1, 8});
  const std::string msg = message_of([&] { read_exif_exposure_seconds(bad); });
  EXPECT_EQ(msg.rfind(bad + ": EXIF Exif.Photo.ExposureTime holds 2 values (1 8)", 0), 0u) << msg;
}

// A JPEG of `rgb` (linear values in [0, 1], stored sRGB-encoded) whose EXIF records the
// exposure time t_num/t_den s, the f-number f_num/f_den and the ISO, as a camera writes them.
std::string jpeg_with_settings(const TempDir& tmp, const std::string& name, int w, int h, const std::vector<float>& rgb,
                               uint32_t t_num, uint32_t t_den, uint32_t f_num, uint32_t f_den, uint32_t iso) {
  const std::string plain = (tmp.path / (name + ".plain.jpg")).string();
  write_display_image(plain, w, h, rgb);  // sRGB-encodes
  ExifTiff t;
  t.u16(3);                                                  // Exif IFD, its tags in order:
  t.u16(0x829A), t.u16(5), t.u32(1), t.u32(68);              // ExposureTime, RATIONAL
  t.u16(0x829D), t.u16(5), t.u32(1), t.u32(76);              // FNumber, RATIONAL
  t.u16(0x8827), t.u16(3), t.u32(1), t.u16(iso), t.u16(0);   // ISOSpeedRatings, SHORT
  t.u32(0);
  t.u32(t_num), t.u32(t_den), t.u32(f_num), t.u32(f_den);
  return write_with_exif(tmp, name, plain, t);
}

// The spread of log(fused / true radiance) of the green channel over the pixels: 0 for a
// fusion at the right ratios, whatever its global scale.
double log_spread(const RgbImage& fused, const std::vector<double>& radiance) {
  double lo = 1e9, hi = -1e9;
  for (size_t i = 0; i < radiance.size(); ++i) {
    const double r = std::log(double(fused.rgb[3 * i + 1]) / radiance[i]);
    lo = std::min(lo, r), hi = std::max(hi, r);
  }
  return hi - lo;
}

// A phone's bracket: the time doubles, the ISO quadruples (exposures 1 : 8 : 64). Read by
// their times alone (1 : 2 : 4) the frames fused at the wrong ratios, with nothing to see: a
// longer time was still the brighter frame.
TEST(ReadBracket, FramesOfAnotherIsoOrApertureAreExposedByItToo) {
  TempDir tmp;
  const int w = 96, h = 8;
  std::vector<double> radiance;  // 6 stops left to right: every pixel well exposed somewhere
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) radiance.push_back(std::exp2(6.0 * u / (w - 1)));
  struct Shot {
    uint32_t t_den, f_num, iso;  // time 1/t_den s, f/(f_num / 10)
  };
  auto bracket = [&](const std::string& name, const std::vector<Shot>& shots) {
    auto exposure_of = [](const Shot& s) { return s.iso / 100.0 / s.t_den / (s.f_num * s.f_num / 100.0); };
    const double scale = 0.5 / (8 * exposure_of(shots[1]));  // the middle frame at half scale mid-scene
    std::vector<std::string> paths;
    for (size_t k = 0; k < shots.size(); ++k) {
      std::vector<float> rgb;
      for (double l : radiance)
        for (int c = 0; c < 3; ++c) rgb.push_back(float(l * exposure_of(shots[k]) * scale));
      paths.push_back(jpeg_with_settings(tmp, name + std::to_string(k) + ".jpg", w, h, rgb, 1, shots[k].t_den,
                                         shots[k].f_num, 10, shots[k].iso));
    }
    return paths;
  };
  auto spread = [&](const Bracket& b) { return log_spread(merge_bracket(b, srgb_response(256), {}), radiance); };
  std::vector<std::string> warnings;
  set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const auto iso = bracket("iso", {{100, 18, 100}, {50, 18, 400}, {25, 18, 1600}});
  const Bracket from_exif = read_bracket(iso);
  const Bracket given = read_bracket(iso, std::vector<double>{0.01, 0.02, 0.04});
  const Bracket aperture = read_bracket(bracket("f", {{100, 80, 200}, {100, 40, 200}, {100, 20, 200}}),
                                        std::vector<double>{0.01, 0.01, 0.01});
  const Bracket plain = read_bracket(bracket("plain", {{400, 18, 100}, {50, 18, 100}, {6, 18, 100}}));
  set_warning_sink(nullptr);
  ASSERT_EQ(warnings.size(), 3u);
  EXPECT_EQ(warnings[0], iso[0] + ": the frames' EXIF ISO 100, 400, 1600 differ: each frame's exposure is taken as its "
                                  "time x ISO / f-number^2, relative to the first");
  EXPECT_EQ(warnings[1], warnings[0]) << "given times are times: the ISO still counts";
  EXPECT_NE(warnings[2].find(": the frames' EXIF f-numbers 8, 4, 2 differ"), std::string::npos) << warnings[2];
  // Measured: 0.043 (ISO), 0.021 (aperture), 0.044 (one ISO), 1.85 by the times alone.
  for (const Bracket* b : {&from_exif, &given}) {
    EXPECT_NEAR(b->exposure_seconds[1] / b->exposure_seconds[0], 8.0, 1e-9);
    EXPECT_NEAR(b->exposure_seconds[2] / b->exposure_seconds[0], 64.0, 1e-9);
    EXPECT_LT(spread(*b), 0.1);
  }
  EXPECT_NEAR(aperture.exposure_seconds[2] / aperture.exposure_seconds[0], 16.0, 1e-9);
  EXPECT_LT(spread(aperture), 0.1);
  EXPECT_EQ(plain.exposure_seconds, (std::vector<double>{1.0 / 400, 1.0 / 50, 1.0 / 6}));
  EXPECT_LT(spread(plain), 0.1) << "the same scene at one ISO: the reference spread";
  Bracket times_only = from_exif;
  times_only.exposure_seconds = {0.01, 0.02, 0.04};
  EXPECT_GT(spread(times_only), 1.0) << "what the times alone gave";
}

// The same scene at ISO 100 f/2, ISO 400 f/2 (a quarter of the time) and ISO 100 f/4 (four
// times the time) gives the same codes. Fused by code / t, the three maps differed 4x and
// 16x: a photometric calibration fitted at one setting was wrong at the others.
TEST(ReadBracket, MapsScaledToTheReferenceExposureAgreeAcrossIsoAndAperture) {
  TempDir tmp;
  const int w = 32, h = 8;
  std::vector<float> low, high;  // the two frames' linear values: a ramp, 4x brighter
  for (int i = 0; i < w * h; ++i)
    for (int c = 0; c < 3; ++c) low.push_back(0.02f + 0.2f * float(i % w) / w), high.push_back(4 * low.back());
  struct Setting {
    uint32_t t_num, t_den, f_num10, iso;  // the short frame; the long one is 4x the time
  };
  auto fused = [&](const std::string& name, const Setting& s) {
    const Bracket b = read_bracket({jpeg_with_settings(tmp, name + "0.jpg", w, h, low, s.t_num, s.t_den, s.f_num10, 10, s.iso),
                                    jpeg_with_settings(tmp, name + "1.jpg", w, h, high, 4 * s.t_num, s.t_den, s.f_num10, 10, s.iso)});
    RgbImage m = merge_bracket(b, srgb_response(256), {});
    const double scale = reference_exposure_scale(b);
    for (float& v : m.rgb) v = float(v * scale);
    return std::pair{m, scale};
  };
  const auto [a, scale_a] = fused("a", {1, 100, 20, 100});
  const auto [b, scale_b] = fused("b", {1, 400, 20, 400});
  const auto [c, scale_c] = fused("c", {4, 100, 40, 100});
  EXPECT_DOUBLE_EQ(scale_a, 4.0);   // f/2: N^2 = 4
  EXPECT_DOUBLE_EQ(scale_b, 1.0);   // ISO 400, f/2
  EXPECT_DOUBLE_EQ(scale_c, 16.0);  // f/4
  for (size_t i = 0; i < a.rgb.size(); i += 3 * 7) {
    EXPECT_NEAR(b.rgb[i] / a.rgb[i], 1.0, 1e-5) << i;  // unscaled: 4
    EXPECT_NEAR(c.rgb[i] / a.rgb[i], 1.0, 1e-5) << i;  // unscaled: 1/4
  }
  Bracket unrecorded;  // no settings: nothing to scale by
  EXPECT_DOUBLE_EQ(reference_exposure_scale(unrecorded), 1.0);
}

// A RAW bracket tagged upside down (a fisheye pointing up records an arbitrary orientation):
// LibRaw turned the frames itself and nothing recorded it, so a fisheye unwrap could not turn
// them back. They are now developed as stored and turned as JPEGs are: where every frame
// agrees, with the turn recorded (Bracket::orientation); where frames disagree, not at all.
TEST(ReadBracket, RawFramesAreTurnedByTheirOrientationAsJpegsAreAndTheTurnIsRecorded) {
  TempDir tmp;
  const int w = 32, h = 24;
  std::vector<uint16_t> codes, brighter;  // a ramp across the columns: stored pixel (0, 0) darkest
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u)
      for (int c = 0; c < 3; ++c) {
        codes.push_back(uint16_t(200 + 300 * u + 50 * v));
        brighter.push_back(uint16_t(4 * (200 + 300 * u + 50 * v)));  // four times the exposure
      }
  RawExposure settings;
  const RgbImage stored = read_camera_raw(write_test_dng(tmp.path, "plain.dng", w, h, codes, 100, 28, 100), &settings);
  EXPECT_EQ(settings.orientation, 1);
  // Every TIFF Orientation comes back as itself through LibRaw's flip (dcraw's "50132467").
  for (uint32_t o = 1; o <= 8; ++o) {
    read_camera_raw(write_test_dng(tmp.path, "o.dng", w, h, codes, 100, 28, 100, o), &settings);
    EXPECT_EQ(settings.orientation, int(o));
  }
  const std::string a = write_test_dng(tmp.path, "a.dng", w, h, codes, 100, 28, 100, 3);
  const std::string b = write_test_dng(tmp.path, "b.dng", w, h, brighter, 25, 28, 100, 3);
  const RgbImage raw = read_camera_raw(a, &settings);
  EXPECT_EQ(settings.orientation, 3);
  EXPECT_EQ(raw.rgb, stored.rgb);  // as stored, not turned by LibRaw
  const Bracket turned = read_bracket({a, b});
  EXPECT_EQ(turned.orientation, 3);
  // Half a turn: the stored first pixel is the shown last one.
  EXPECT_EQ(turned.frames[0].rgb[turned.frames[0].rgb.size() - 2], stored.rgb[1]);
  EXPECT_EQ(turned_back_to_sensor(RgbImage{w, h, turned.frames[0].rgb, {}, Units::Relative, 0, 3}).rgb, stored.rgb);
  // One frame tagged otherwise: both as stored, said once.
  const std::string c = write_test_dng(tmp.path, "c.dng", w, h, brighter, 25, 28, 100, 1);
  std::vector<std::string> warnings;
  set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const Bracket mixed = read_bracket({a, c});
  set_warning_sink(nullptr);
  EXPECT_EQ(mixed.orientation, 1);
  EXPECT_EQ(mixed.frames[0].rgb, stored.rgb);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("EXIF Orientation disagree (3, 1)"), std::string::npos) << warnings[0];
}

// The same blindness in RAW brackets: LibRaw reads the ISO and f-number, the bracket used
// only the shutter time. An auto-ISO RAW bracket (time x2, ISO x4 per frame) fused at the
// times' ratios 1 : 2 : 4 instead of 1 : 8 : 64.
TEST(ReadBracket, RawFramesOfAnotherIsoAreExposedByItToo) {
  TempDir tmp;
  const int w = 96, h = 24;  // LibRaw takes no image under 22 pixels a side for RAW
  std::vector<double> radiance;  // 6 stops left to right
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) radiance.push_back(std::exp2(6.0 * u / (w - 1)));
  const uint32_t t_den[] = {100, 50, 25}, iso[] = {100, 400, 1600};
  std::vector<std::string> paths;
  for (int k = 0; k < 3; ++k) {
    const double exposure = iso[k] / 100.0 / t_den[k];  // 0.01, 0.08, 0.64
    const double scale = 0.5 / (8 * 0.08);                // the middle frame at half scale mid-scene
    std::vector<uint16_t> codes;
    for (double l : radiance)
      for (int c = 0; c < 3; ++c) codes.push_back(uint16_t(std::lround(std::min(1.0, l * exposure * scale) * 65535)));
    paths.push_back(write_test_dng(tmp.path, "raw" + std::to_string(k) + ".dng", w, h, codes, t_den[k], 28, iso[k]));
  }
  std::vector<std::string> warnings;
  set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const Bracket b = read_bracket(paths);
  set_warning_sink(nullptr);
  ASSERT_TRUE(b.linear);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("ISO 100, 400, 1600 differ"), std::string::npos) << warnings[0];
  EXPECT_NEAR(b.exposure_seconds[1] / b.exposure_seconds[0], 8.0, 1e-9);
  EXPECT_NEAR(b.exposure_seconds[2] / b.exposure_seconds[0], 64.0, 1e-9);
  auto spread = [&](const Bracket& bracket) { return log_spread(merge_bracket(bracket, linear_response(65536), {}), radiance); };
  EXPECT_LT(spread(b), 0.1);
  Bracket times_only = b;
  times_only.exposure_seconds = {0.01, 0.02, 0.04};
  EXPECT_GT(spread(times_only), 1.0) << "what the times alone gave";
}

// `jpeg` with an APP1 Exif segment stating EXIF Orientation `orientation`, in the byte
// order a camera chose, spliced in after the start-of-image marker.
std::string jpeg_with_orientation(const std::string& jpeg, int orientation, bool little_endian) {
  std::string tiff;
  auto u16 = [&](uint32_t v) {
    if (little_endian)
      tiff += char(v & 0xff), tiff += char((v >> 8) & 0xff);
    else
      tiff += char((v >> 8) & 0xff), tiff += char(v & 0xff);
  };
  auto u32 = [&](uint32_t v) {
    if (little_endian)
      u16(v & 0xffff), u16(v >> 16);
    else
      u16(v >> 16), u16(v & 0xffff);
  };
  tiff += little_endian ? "II" : "MM", u16(42), u32(8);
  u16(2), u16(0x010F), u16(2), u32(4), tiff += std::string("Foo\0", 4);  // Make, then Orientation
  u16(0x0112), u16(3), u32(1), u16(uint32_t(orientation)), u16(0), u32(0);
  const std::string app1 = std::string("Exif\0\0", 6) + tiff;
  const size_t length = app1.size() + 2;
  return jpeg.substr(0, 2) + char(0xFF) + char(0xE1) + char(length >> 8) + char(length & 0xff) + app1 + jpeg.substr(2);
}

// A phone held upright stores its pixels sideways and says so in EXIF Orientation: the
// frames are read as viewers show them, as OpenCV's imread (the peer) and LibRaw do, in all
// eight orientations and both byte orders; a bracket of them is upright (portrait).
TEST(ReadCameraImage, TurnsJpegsAsTheirExifOrientationSays) {
  TempDir tmp;
  cv::Mat stored(5, 7, CV_8UC3);
  cv::randu(stored, 0, 256);
  std::vector<uint8_t> encoded;
  ASSERT_TRUE(cv::imencode(".jpg", stored, encoded, {cv::IMWRITE_JPEG_QUALITY, 100}));
  const std::string jpeg(encoded.begin(), encoded.end());
  const std::string plain = (tmp.path / "plain.jpg").string();
  std::ofstream(plain, std::ios::binary) << jpeg;
  const CameraImage as_stored = read_camera_image(plain);
  ASSERT_EQ(as_stored.width, 7);
  auto stored_at = [&](int x, int y, int c) { return as_stored.rgb[3 * size_t(y * 7 + x) + size_t(c)]; };
  for (const bool little : {true, false})
    for (int o = 1; o <= 8; ++o) {
      SCOPED_TRACE(testing::Message() << "orientation " << o << (little ? " II" : " MM"));
      const std::string path = (tmp.path / ("o" + std::to_string(o) + ".jpg")).string();
      std::ofstream(path, std::ios::binary) << jpeg_with_orientation(jpeg, o, little);
      const CameraImage ours = read_camera_image(path);
      const cv::Mat peer = cv::imread(path, cv::IMREAD_COLOR);
      ASSERT_EQ(ours.width, peer.cols);
      ASSERT_EQ(ours.height, peer.rows);
      EXPECT_EQ(ours.width, o >= 5 ? 5 : 7);
      // The header alone gives the same size (corners.vnl's --imagersize check reads it so).
      EXPECT_EQ(camera_image_size(path), std::make_pair(ours.width, ours.height));
      for (int y = 0; y < peer.rows; ++y)
        for (int x = 0; x < peer.cols; ++x)
          for (int c = 0; c < 3; ++c)
            ASSERT_EQ(ours.rgb[3 * size_t(y * ours.width + x) + size_t(c)],
                      float(peer.at<cv::Vec3b>(y, x)[2 - c]) * (1.0f / 255.0f))
                << x << "," << y;
      // The corner a viewer shows top left, from the EXIF specification's table.
      const int corner[9][2] = {{0, 0}, {0, 0}, {6, 0}, {6, 4}, {0, 4}, {0, 0}, {0, 4}, {6, 4}, {6, 0}};
      EXPECT_EQ(ours.rgb[0], stored_at(corner[o][0], corner[o][1], 0));
    }
  // A portrait bracket: two frames stored 7x5, shown and fused 5x7.
  const std::string a = (tmp.path / "o6.jpg").string(), b = (tmp.path / "o6b.jpg").string();
  fs::copy_file(a, b);
  const Bracket bracket = read_bracket({a, b}, std::vector<double>{0.5, 0.125});
  EXPECT_EQ(bracket.frames[0].width, 5);
  EXPECT_EQ(bracket.frames[0].height, 7);
  EXPECT_EQ(bracket.orientation, 6);  // what a lens's vignetting model is turned by (hdr fuse --vignetting)
  // Frames whose Orientation disagree (one camera does not turn between the frames of a
  // bracket: a camera pointing up records an arbitrary one) are read as stored, said once.
  // This had been refused for the size the turn gave one frame; frames upside down among
  // upright ones had been merged turned against them.
  std::vector<std::string> warnings;
  const WarningSink before = set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const Bracket mixed = read_bracket({a, b, plain}, std::vector<double>{0.5, 0.125, 1});
  set_warning_sink(before);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], a + ": the frames' EXIF Orientation disagree (6, 6, 1): one camera did not turn between the "
                             "frames of a bracket, so they are read as stored");
  EXPECT_EQ(mixed.orientation, 1);
  for (const RgbImage& f : mixed.frames) {
    EXPECT_EQ(f.width, 7);
    EXPECT_EQ(f.rgb, as_stored.rgb);
  }
}

// Camera codes are taken as sRGB; a bracket whose files carry another ICC profile (the
// Kartik iPhone photos: Apple's wide-colour LUT profile) says so in one warning, once; an
// sRGB or profile-less bracket says nothing.
TEST(ReadBracket, AnIccProfileThatIsNotSrgbIsWarnedAboutOnce) {
  std::vector<std::string> warnings;
  const WarningSink before = set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const std::string photo = kData + "/hdr-mirrorball-kartik/ball_1-10s.jpg";
  // Its shorter frame: a dark image of its size (the same file twice is not a bracket).
  TempDir tmp;
  const std::string dark = (tmp.path / "dark.png").string();
  write_display_image(dark, 480, 472, std::vector<float>(3 * 480 * 472, 0.01f));
  const Bracket b = read_bracket({photo, dark}, std::vector<double>{0.1, 0.025});
  EXPECT_EQ(b.frames.size(), 2u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], photo + ": its ICC profile ('Apple Wide Color Sharing Profile') is not applied: its colours are "
                                 "taken as sRGB");
  warnings.clear();
  read_bracket({photo, dark}, std::vector<double>{0.1, 0.025});  // the same profile again: said once
  const std::string m = kData + "/hdr-memorial-debevec/";
  read_bracket({m + "memorial0066.png", m + "memorial0068.png"}, std::vector<double>{0.125, 0.03125});
  EXPECT_TRUE(warnings.empty());
  set_warning_sink(before);
}

// A bracket whose JPEGs carry a matrix ICC profile other than sRGB (Display P3, as in an
// APP2 ICC_PROFILE segment) gets the matrix to Rec. 709 for hdr fuse to apply, and no warning;
// its white (the colorants' sum, D50) stays white.
TEST(ReadBracket, AMatrixIccProfileIsAppliedNotWarnedAbout) {
  TempDir tmp;
  const std::string icc = icc_blob("Display P3", &kP3Colorants);
  auto with_icc = [&](const std::string& name) {
    const std::string plain = tmp.png(name + ".plain.jpg", 8, 6);
    std::ifstream in(plain, std::ios::binary);
    const std::string jpeg((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const std::string app2 = std::string("ICC_PROFILE\0", 12) + char(1) + char(1) + icc;
    const size_t length = app2.size() + 2;
    const std::string path = (tmp.path / name).string();
    std::ofstream(path, std::ios::binary) << jpeg.substr(0, 2) << char(0xFF) << char(0xE2) << char(length >> 8)
                                          << char(length & 0xff) << app2 << jpeg.substr(2);
    return path;
  };
  std::vector<std::string> warnings;
  const WarningSink before = set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const Bracket b = read_bracket({with_icc("a.jpg"), with_icc("b.jpg")}, std::vector<double>{0.5, 0.125});
  set_warning_sink(before);
  EXPECT_TRUE(warnings.empty()) << warnings[0];
  ASSERT_TRUE(b.to_rec709.has_value());
  EXPECT_EQ(b.colour_profile, "Display P3");
  const auto expected = icc_colorants_to_rec709(*summarize_icc_profile(icc), "test");
  for (int i = 0; i < 9; ++i) EXPECT_DOUBLE_EQ((*b.to_rec709)[size_t(i)], expected[size_t(i)]);
  const auto& m = *b.to_rec709;
  for (int r = 0; r < 3; ++r) EXPECT_NEAR(m[size_t(3 * r)] + m[size_t(3 * r + 1)] + m[size_t(3 * r + 2)], 1.0, 2e-4);
  // P3's red is more saturated than Rec. 709's: out of its gamut, with negative green and blue.
  EXPECT_GT(m[0], 1.1);
  EXPECT_LT(m[3], 0.0);
}

TEST(ReadExposureList, ReadsTheSharedCsvsDebevecsListAndPlainLines) {
  const auto memorial = read_exposure_list(kData + "/hdr-memorial-debevec/exposures.csv");
  ASSERT_EQ(memorial.size(), 16u);
  EXPECT_DOUBLE_EQ(memorial[0], 32.0);
  EXPECT_DOUBLE_EQ(memorial[15], 0.0009765625);
  EXPECT_EQ(read_exposure_list(kData + "/hdr-memorial-debevec/hdr_image_list.txt"), memorial);
  TempDir tmp;
  EXPECT_EQ(read_exposure_list(tmp.text("plain.txt", "# seconds\n0.5\n\n1/40\n2e-3\n")),
            (std::vector<double>{0.5, 1.0 / 40, 2e-3}));
  EXPECT_NE(message_of([&] { read_exposure_list(tmp.text("neg.txt", "0.5\n-1\n")); }).find("neg.txt:2"),
            std::string::npos);
  EXPECT_THROW(read_exposure_list(tmp.text("junk.csv", "a,b\nx,y\n")), InputError);
  EXPECT_THROW(read_exposure_list(tmp.text("empty.txt", "# nothing\n")), InputError);
}

// A list that names its files is read by name: glob order is not the list's (ls sorts
// ball_1-160s.jpg before ball_1-40s.jpg), and a subset of a bracket is a bracket. Read in
// order, both gave frames another frame's time.
TEST(ReadExposureList, AListThatNamesItsFilesIsReadByName) {
  const std::string kartik = kData + "/hdr-mirrorball-kartik/";
  EXPECT_EQ(exposure_times_for(kartik + "exposures.csv",
                               {kartik + "ball_1-10s.jpg", kartik + "ball_1-160s.jpg", kartik + "ball_1-40s.jpg"}),
            (std::vector<double>{0.1, 1.0 / 160, 1.0 / 40}));
  const std::string m = kData + "/hdr-memorial-debevec/";
  for (const std::string list : {"exposures.csv", "hdr_image_list.txt"}) {
    EXPECT_EQ(exposure_times_for(m + list, {m + "memorial0070.png", "memorial0066.png", m + "memorial0068.png"}),
              (std::vector<double>{0.0625, 1.0, 0.25}))
        << list;
  }
  TempDir tmp;
  const std::string named = tmp.text("named.csv", "file,seconds\na/x.png,0.5\nb/x.png,0.25\ny.png,1\n");
  EXPECT_EQ(exposure_times_for(named, {"b/x.png", "y.png"}), (std::vector<double>{0.25, 1.0}))
      << "a path as given wins over a file name";
  EXPECT_EQ(message_of([&] { exposure_times_for(named, {"c/x.png"}); }), named + ": lines 2 and 3 both name c/x.png");
  EXPECT_EQ(exposure_times_for(kartik + "exposures.csv", {"registered/ball_1-40s.png", "registered/ball_1-10s.png"}),
            (std::vector<double>{1.0 / 40, 0.1}))
      << "a photo registered to PNG (probe register) finds its line by its stem";
  EXPECT_EQ(message_of([&] { exposure_times_for(named, {"z.png"}); }),
            named + ": no line names z.png (the list names its files)");
  const std::string mixed = tmp.text("mixed.csv", "x.png,0.5\n0.25\n");
  EXPECT_EQ(message_of([&] { exposure_times_for(mixed, {"x.png"}); }),
            mixed + ":2: a time without a file name in a list that names its files");
  const std::string bare = tmp.text("bare.txt", "0.5\n0.25\n");
  EXPECT_EQ(exposure_times_for(bare, {"q.png", "p.png"}), (std::vector<double>{0.5, 0.25})) << "times alone: in order";
  EXPECT_EQ(message_of([&] { exposure_times_for(bare, {"q.png"}); }),
            bare + ": 2 times for 1 images (a list of times alone is read in order)");
}

// A frame at the exposure of an earlier one (a camera at its shortest time repeats it when an
// auto-bracket asks for more) is used once, said in one line: the bracket reads as without it.
// It had refused the bracket whole. Two frames given one time whose codes say otherwise (a
// typo in the list: memorial0065 is 2 s, not 4) are refused, naming both.
TEST(ReadBracket, AFrameAtTheExposureOfAnEarlierOneIsUsedOnce) {
  TempDir tmp;
  const std::string dir = kData + "/hdr-memorial-debevec/";
  const std::string copy = (tmp.path / "memorial0064_again.png").string();
  fs::copy_file(dir + "memorial0064.png", copy);
  std::vector<std::string> warnings;
  set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const Bracket plain = read_bracket({dir + "memorial0063.png", dir + "memorial0064.png", dir + "memorial0065.png"},
                                     std::vector<double>{8, 4, 2});
  const Bracket again = read_bracket(
      {dir + "memorial0063.png", dir + "memorial0064.png", copy, dir + "memorial0065.png"}, std::vector<double>{8, 4, 4, 2});
  set_warning_sink(nullptr);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0], "1 frame repeats the exposure of an earlier one, each exposure used once: " + copy + " = " + dir +
                             "memorial0064.png (4 s)");
  EXPECT_EQ(again.paths, plain.paths);
  EXPECT_EQ(again.exposure_seconds, plain.exposure_seconds);
  ASSERT_EQ(again.frames.size(), 3u);
  for (size_t k = 0; k < 3; ++k) EXPECT_EQ(again.frames[k].rgb, plain.frames[k].rgb);
  EXPECT_EQ(again.codes, plain.codes);
  const std::string wrong = message_of([&] {
    read_bracket({dir + "memorial0063.png", dir + "memorial0064.png", dir + "memorial0065.png"},
                 std::vector<double>{8, 4, 4});
  });
  EXPECT_NE(wrong.find(dir + "memorial0064.png and " + dir + "memorial0065.png: the same exposure 4 s, but their codes "
                       "are"),
            std::string::npos)
      << wrong;
  EXPECT_NE(wrong.find("a time is wrong"), std::string::npos) << wrong;
}

// Photos registered together record one ball (probe register), which the bracket keeps for
// hdr fuse to record; frames that record another, or none, were not registered together: the
// bracket keeps none, said in one line.
TEST(ReadBracket, PhotosRegisteredTogetherKeepTheirBallOthersKeepNone) {
  TempDir tmp;
  const std::string dir = kData + "/hdr-memorial-debevec/";
  std::vector<std::string> paths;
  for (const char* name : {"memorial0063", "memorial0064", "memorial0065"}) {
    RgbImage f = read_rgb_image(dir + name + ".png");
    f.mirror_ball = std::array<double, 3>{256.5, 384.25, 200};
    paths.push_back((tmp.path / (std::string(name) + ".png")).string());
    write_code_image(paths.back(), f, 8);
  }
  std::vector<std::string> warnings;
  set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const Bracket together = read_bracket(paths, std::vector<double>{8, 4, 2});
  EXPECT_TRUE(warnings.empty());
  ASSERT_TRUE(together.mirror_ball.has_value());
  EXPECT_EQ(*together.mirror_ball, (std::array<double, 3>{256.5, 384.25, 200}));
  const Bracket mixed = read_bracket({paths[0], paths[1], dir + "memorial0065.png"}, std::vector<double>{8, 4, 2});
  set_warning_sink(nullptr);
  EXPECT_FALSE(mixed.mirror_ball.has_value());
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find(paths[0] + ": the frames do not record one mirror ball"), std::string::npos) << warnings[0];
}

TEST(ReadBracket, RefusesBadInputWithOneLineNamingTheFile) {
  TempDir tmp;
  const std::string a = tmp.png("a.png", 8, 6), b = tmp.png("b.png", 8, 6), odd = tmp.png("odd.png", 7, 8);
  // One exposure.
  EXPECT_THROW(read_bracket({a}, std::vector<double>{1.0}), InputError);
  // Different sizes: the odd file is named.
  const std::string size_msg = message_of([&] { read_bracket({a, odd}, std::vector<double>{1.0, 2.0}); });
  EXPECT_NE(size_msg.find("odd.png"), std::string::npos) << size_msg;
  // The odd size is named when it is the first frame, too.
  const std::string first_msg = message_of([&] { read_bracket({odd, a, b}, std::vector<double>{1.0, 2.0, 4.0}); });
  EXPECT_EQ(first_msg, odd + ": size 7x8 differs from the 8x6 of 2 of the 3 images");
  // Every frame at one exposure time: both named.
  const std::string same_msg = message_of([&] { read_bracket({a, b}, std::vector<double>{0.5, 0.5}); });
  EXPECT_EQ(same_msg, a + " and " + b + ": the same exposure time 0.5 s, as every frame: a bracket needs at least 2 exposures");
  // No EXIF in a PNG and no times given.
  const std::string exif_msg = message_of([&] { read_bracket({a, b}); });
  EXPECT_EQ(exif_msg, a + ": no exposure time in EXIF; give --exposure-times");
  // Non-positive and non-finite times, wrong counts.
  EXPECT_NE(message_of([&] { read_bracket({a, b}, std::vector<double>{1.0, 0.0}); }).find("b.png"), std::string::npos);
  EXPECT_THROW(read_bracket({a, b}, std::vector<double>{1.0, -2.0}), InputError);
  EXPECT_THROW(read_bracket({a, b}, std::vector<double>{1.0, std::nan("")}), InputError);
  EXPECT_THROW(read_bracket({a, b}, std::vector<double>{1.0}), InputError);
  // A missing file.
  EXPECT_THROW(read_bracket({a, (tmp.path / "missing.png").string()}, std::vector<double>{1.0, 2.0}), InputError);
  for (const std::string& m : {size_msg, exif_msg}) EXPECT_EQ(m.find('\n'), std::string::npos);
  // A good one: times kept matched to frames.
  const Bracket ok = read_bracket({a, b}, std::vector<double>{0.5, 0.25});
  EXPECT_EQ(ok.exposure_seconds, (std::vector<double>{0.5, 0.25}));
  EXPECT_EQ(ok.width(), 8);
  EXPECT_EQ(ok.height(), 6);
  // A grey frame among colour ones (an audit's) was merged, its grey tinting the pixels it
  // exposed best; an all-grey bracket (a monochrome camera) stays fine.
  const std::string grey = (tmp.path / "grey.png").string(), grey2 = (tmp.path / "grey2.png").string();
  cv::imwrite(grey, cv::Mat(6, 8, CV_8UC1, cv::Scalar(60)));
  cv::imwrite(grey2, cv::Mat(6, 8, CV_8UC1, cv::Scalar(120)));
  const std::string mixed = message_of([&] { read_bracket({a, grey}, std::vector<double>{0.5, 0.25}); });
  EXPECT_NE(mixed.find(grey + ": a grey image in a bracket of colour images"), std::string::npos) << mixed;
  EXPECT_EQ(read_bracket({grey2, grey}, std::vector<double>{0.5, 0.25}).frames.size(), 2u);
}

// A longer exposure is brighter: times that say the opposite are not the frames' (a list
// given in another order), and were fused into a wrong map with exit 0. The memorial
// bracket's 32 s and 1 s frames, with their times and swapped.
TEST(ReadBracket, TimesInAnotherOrderThanTheFramesBrightnessAreRefused) {
  const std::string m = kData + "/hdr-memorial-debevec/";
  const std::string bright = m + "memorial0061.png", dark = m + "memorial0066.png";
  EXPECT_NO_THROW(read_bracket({bright, dark}, std::vector<double>{32, 1}));
  EXPECT_EQ(message_of([&] { read_bracket({bright, dark}, std::vector<double>{1, 32}); }),
            dark + " (32 s) is darker than " + bright + " (1 s) in 100 % of the sampled values they both expose: the " +
                "exposure times given (--exposure-times) are not these frames' (another order?)");
}

// A 12-bit camera's codes saved as they came in 16-bit PNGs (Mono12 to PNG): clipped at
// 4095, which a merge that knows only 65535 as saturated took for a valid value. The same
// codes shifted to the top bits (the 16-bit PNG a careful writer makes) are the reference.
TEST(ReadBracket, SixteenBitFilesOfATwelveBitSensorAreReadAtItsWhiteLevel) {
  TempDir tmp;
  const std::vector<double> times{1.0 / 64, 1.0 / 8, 1.0};
  const int w = 64, h = 32;
  // Radiance over 13 stops, every pixel its own value, so that only clipping repeats a code.
  auto write = [&](const std::string& name, double gain, int shift) {
    std::vector<std::string> paths;
    for (size_t k = 0; k < times.size(); ++k) {
      RgbImage f;
      f.width = w;
      f.height = h;
      for (int i = 0; i < w * h; ++i) {
        const double l = 0.5 * std::exp(std::log(8000.0) * i / (w * h - 1));
        for (const double c : {1.0, 0.8, 0.6}) {
          const double code = std::min(4095.0, std::round(gain * l * c * times[k]));
          f.rgb.push_back(float(code * (1 << shift) / 65535.0));
        }
      }
      paths.push_back((tmp.path / (name + std::to_string(k) + ".png")).string());
      write_code_image(paths.back(), f, 16);
    }
    return paths;
  };
  std::vector<std::string> warnings;
  set_warning_sink([&](const std::string& line) { warnings.push_back(line); });
  const Bracket low = read_bracket(write("low", 40, 0), times);
  const Bracket high = read_bracket(write("high", 40, 4), times);
  const Bracket dark = read_bracket(write("dark", 0.5, 0), times);  // clips nowhere
  set_warning_sink(nullptr);
  EXPECT_EQ(low.white_level, 4095);
  EXPECT_EQ(high.white_level, 0);
  EXPECT_EQ(dark.white_level, 0);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("low0.png: the 16-bit codes of all 3 frames stop at 4095"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("read as a 12-bit sensor's codes, white level 4095"), std::string::npos) << warnings[0];
  size_t clipped = 0;
  for (size_t k = 0; k < 3; ++k)
    for (size_t i = 0; i < low.frames[k].rgb.size(); ++i) {
      const double c = std::round(double(high.frames[k].rgb[i]) * 65535.0 / 16.0);  // the 12-bit code
      ASSERT_FLOAT_EQ(low.frames[k].rgb[i], float(c / 4095.0));
      clipped += c == 4095;
    }
  EXPECT_GT(clipped, 1000u);
  EXPECT_EQ(dark.frames[2].rgb.back(), float(std::round(0.5 * 0.5 * 8000 * 0.6) / 65535.0)) << "left as read";
  // Fused: the clipped highlights now come from the short frames, as with the top-bit codes.
  const RgbImage a = merge_bracket(low, linear_response(1024), {});
  const RgbImage b = merge_bracket(high, linear_response(1024), {});
  double sum_a = 0, sum_b = 0, worst = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) {
    sum_a += a.rgb[i];
    sum_b += b.rgb[i];
    worst = std::max(worst, std::abs(std::log(double(a.rgb[i]) / double(b.rgb[i]))));
  }
  EXPECT_NEAR(sum_a / sum_b, 1.0, 1e-3);
  EXPECT_LT(worst, 0.01);
}

// An 8-bit bracket keeps its codes (Bracket::codes): each the file's code, as its float
// k / 255 says, and merging through them is merging the floats, bit for bit. 16-bit files keep none.
TEST(ReadBracket, Keeps8BitCodesThatMergeAsTheFloats) {
  const std::string dir = kData + "/hdr-memorial-debevec/";
  const Bracket b = read_bracket({dir + "memorial0064.png", dir + "memorial0066.png", dir + "memorial0068.png"},
                                 std::vector<double>{4.0, 1.0, 0.25});
  ASSERT_EQ(b.bit_depth, 8);
  ASSERT_EQ(b.codes.size(), 3u);
  size_t ends = 0;
  for (size_t k = 0; k < 3; ++k) {
    ASSERT_EQ(b.codes[k].size(), b.frames[k].rgb.size());
    for (size_t i = 0; i < b.codes[k].size(); ++i) {
      const float v = b.frames[k].rgb[i];
      ASSERT_EQ(long(b.codes[k][i]), std::lround(double(v) * 255.0)) << "frame " << k << ", value " << i;
      ASSERT_EQ(v, float(b.codes[k][i]) * (1.0f / 255.0f));  // an 8-bit code exactly
      ends += b.codes[k][i] == 0 || b.codes[k][i] == 255;
    }
  }
  EXPECT_GT(ends, 1000u);  // the codes' ends are there (Memorial's black border, clipped windows)
  Bracket floats = b;
  floats.codes.clear();
  for (const bool simd : {true, false}) {
    MergeOptions o;
    o.simd = simd;
    o.flag_image = true;
    MergeReport with, without;
    const RgbImage x = merge_bracket(b, linear_response(256), o, &with);
    const RgbImage y = merge_bracket(floats, linear_response(256), o, &without);
    EXPECT_EQ(0, std::memcmp(x.rgb.data(), y.rgb.data(), x.rgb.size() * sizeof(float))) << "simd " << simd;
    EXPECT_EQ(with.flags, without.flags);
    EXPECT_EQ(with.well_exposed, without.well_exposed);
  }
  TempDir tmp;
  RgbImage deep;
  deep.width = 4;
  deep.height = 3;
  deep.rgb.assign(36, 0.3f);
  const std::string a = (tmp.path / "a16.png").string(), c = (tmp.path / "c16.png").string();
  write_code_image(a, deep, 16);
  write_code_image(c, deep, 16);
  const Bracket sixteen = read_bracket({a, c}, std::vector<double>{1.0, 2.0});
  EXPECT_EQ(sixteen.bit_depth, 16);
  EXPECT_TRUE(sixteen.codes.empty());
}

TEST(CheckBracket, NamesInMemoryFramesByIndex) {
  Bracket b = test::photograph(test::random_radiance(4, 4, 0.1, 1.0), {1.0, 2.0}, test::gamma_curve());
  EXPECT_NO_THROW(check_bracket(b));
  b.frames[1].width = 3;
  EXPECT_NE(message_of([&] { check_bracket(b); }).find("bracket frame 1"), std::string::npos);
}

}  // namespace
}  // namespace lp

namespace lp {
namespace {

// A frame warped by a registration tool (Hugin's align_image_stack -a) is transparent where
// it has no data: alpha 0 and RGB 0. Alpha was dropped, so those pixels fused as black codes
// (median 1.38x, p95 4x off in the strip). Now they are no data in that frame: the fused
// strip is the other frames' answer, as in the opaque bracket, and said in one warning.
TEST(ReadBracket, TransparentPixelsOfAFrameAreNoDataNotBlack) {
  TempDir tmp;
  const RgbImage radiance = test::random_radiance(64, 48, 0.05, 20.0);
  const std::vector<double> times{1.0, 0.25, 1.0 / 16};
  const Bracket truth = test::photograph(radiance, times, test::gamma_curve());
  std::vector<std::string> opaque, holed;
  for (size_t k = 0; k < 3; ++k) {
    cv::Mat rgba(48, 64, CV_16UC4);
    for (int y = 0; y < 48; ++y)
      for (int x = 0; x < 64; ++x) {
        const float* p = &truth.frames[k].rgb[3 * (size_t(y) * 64 + size_t(x))];
        rgba.at<cv::Vec4w>(y, x) = {uint16_t(std::lround(p[2] * 65535)), uint16_t(std::lround(p[1] * 65535)),
                                    uint16_t(std::lround(p[0] * 65535)), 65535};
      }
    const std::string a = (tmp.path / ("opaque" + std::to_string(k) + ".png")).string();
    cv::imwrite(a, rgba);
    opaque.push_back(a);
    if (k < 2)  // the two longer frames lose a 10 px strip on the left, as a warp leaves it
      for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 10; ++x) rgba.at<cv::Vec4w>(y, x) = {0, 0, 0, 0};
    const std::string b = (tmp.path / ("holed" + std::to_string(k) + ".png")).string();
    cv::imwrite(b, rgba);
    holed.push_back(b);
  }
  std::vector<std::string> warnings;
  set_warning_sink([&](const std::string& w) { warnings.push_back(w); });
  const Bracket full = read_bracket(opaque, times);
  EXPECT_TRUE(warnings.empty());
  for (const RgbImage& f : full.frames) EXPECT_TRUE(f.valid.empty());  // opaque alpha: no mask
  const Bracket cut = read_bracket(holed, times);
  set_warning_sink(nullptr);
  ASSERT_EQ(warnings.size(), 2u);
  EXPECT_NE(warnings[0].find("holed0.png: 480 pixels"), std::string::npos) << warnings[0];
  ASSERT_EQ(cut.frames[0].valid.size(), size_t(64 * 48));
  EXPECT_EQ(cut.frames[0].valid[0], 0);
  EXPECT_EQ(cut.frames[0].valid[10], 1);
  EXPECT_TRUE(cut.frames[2].valid.empty());
  const CameraResponse response = test::true_response(test::gamma_curve());
  const RgbImage a = merge_bracket(full, response), b = merge_bracket(cut, response);
  // In the strip only the shortest frame speaks: its merge there, not one pulled to black.
  std::vector<uint8_t> strip(size_t(64 * 48), 0);
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 10; ++x) strip[size_t(y) * 64 + size_t(x)] = 1;
  const test::LogError e = test::log10_luminance_error(b, radiance, strip);
  EXPECT_GT(e.count, 400u);
  EXPECT_LT(e.median, 0.05);  // one 8-bit frame of a gamma curve; black codes were off 0.14 decades
  const test::LogError outside = test::log10_luminance_error(b, a, [&] {
    std::vector<uint8_t> v(strip.size());
    for (size_t i = 0; i < v.size(); ++i) v[i] = !strip[i];
    return v;
  }());
  EXPECT_LT(outside.p95, 1e-6);  // elsewhere the same as the opaque bracket
}

}  // namespace
}  // namespace lp
