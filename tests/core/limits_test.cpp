// The limits of core/limits.h and the readers that check them from the header, before
// allocating: tiny crafted files that claim huge images are refused in one line naming the
// file and the limit, by the header check (the message says which check refused, so the
// decoder never ran), and the process's peak memory does not grow by what they claim.
#include "core/limits.h"

#include <gtest/gtest.h>

#include <sys/resource.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/image_header.h"
#include "core/image_io.h"
#include "tests/core/test_files.h"

namespace fs = std::filesystem;

namespace lp {
namespace {

const std::string kData = LIGHTPROBE_SHARED_DATA;
const std::string kJpeg = kData + "/calib-opencv-stereo-9x6/left01.jpg";       // 640x480 grey, 27.9 KB
const std::string kPng = kData + "/hdr-memorial-debevec/memorial0064.png";      // 512x768 RGB

using test_files::read_bytes;
using test_files::write_bytes;
std::string temp_dir() { return test_files::temp_dir("lightprobe_limits"); }

void put_be16(std::string& b, size_t at, uint32_t v) {
  b[at] = char(v >> 8);
  b[at + 1] = char(v & 0xff);
}
void put_be32(std::string& b, size_t at, uint32_t v) {
  put_be16(b, at, v >> 16);
  put_be16(b, at + 2, v & 0xffff);
}
void put_le32(std::string& b, size_t at, uint32_t v) {
  for (int k = 0; k < 4; ++k) b[at + size_t(k)] = char((v >> (8 * k)) & 0xff);
}

// Growth of the process's peak resident memory while `f` runs, in MB.
double peak_growth_mb(const std::function<void()>& f) {
  rusage before{}, after{};
  getrusage(RUSAGE_SELF, &before);
  f();
  getrusage(RUSAGE_SELF, &after);
  return double(after.ru_maxrss - before.ru_maxrss) / 1024.0;
}

// `f` must throw an InputError of one line holding every fragment, without the peak memory
// growing by more than 64 MB (the claimed images are gigabytes).
void expect_fast_refusal(const std::function<void()>& f, std::initializer_list<std::string> fragments) {
  std::string message;
  const double growth = peak_growth_mb([&] {
    try {
      f();
      ADD_FAILURE() << "nothing thrown";
    } catch (const InputError& e) {
      message = e.what();
    }
  });
  EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  for (const auto& frag : fragments) EXPECT_NE(message.find(frag), std::string::npos) << "'" << frag << "' not in: " << message;
  EXPECT_LT(growth, 64.0) << message;
}

// Raises the limits for one scope, so that the checks behind the pixel limit are reached.
class RaisedLimits {
 public:
  explicit RaisedLimits(uint64_t max_pixels) {
    Limits l = limits();
    l.max_pixels = max_pixels;
    set_limits(l);
  }
  ~RaisedLimits() { set_limits(Limits{}); }
};

// The SOF0 frame header's offset in a baseline JPEG.
size_t sof_offset(const std::string& jpeg) {
  for (size_t i = 2; i + 3 < jpeg.size();) {
    if (uint8_t(jpeg[i + 1]) == 0xC0) return i;
    i += 2 + (size_t(uint8_t(jpeg[i + 2])) << 8 | uint8_t(jpeg[i + 3]));
  }
  return 0;
}

std::string forged_jpeg(uint32_t width, uint32_t height) {
  std::string b = read_bytes(kJpeg);
  const size_t sof = sof_offset(b);
  EXPECT_GT(sof, 0u);
  put_be16(b, sof + 5, height);
  put_be16(b, sof + 7, width);
  return b;
}

TEST(Limits, DefaultsAndDerivedLimitsAreWhatDocsLimitsMdSays) {
  const Limits l;
  EXPECT_EQ(l.max_pixels, uint64_t(1) << 27);
  EXPECT_EQ(l.max_side, 65535);
  EXPECT_EQ(l.max_lights, 1000000);
  EXPECT_EQ(l.max_lut, 1024);
  EXPECT_EQ(l.max_frames, 10000);
  EXPECT_EQ(max_nside(), 2048);  // 12 * 2048^2 = 50 M pixels; 4096 would be 201 M
  EXPECT_EQ(max_image_file_bytes(), (uint64_t(4) << 30) + (uint64_t(16) << 20));
  RaisedLimits raised(12ull * 4096 * 4096);
  EXPECT_EQ(max_nside(), 4096);
}

TEST(Limits, ChecksNameWhoAskedTheSizeAndTheLimit) {
  check_image_size("--size", 16384, 8192);  // the largest default latlong passes
  try {
    check_image_size("--size", 16384, 16384);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "--size: image 16384x16384 has 268435456 pixels, over the limit of 134217728 (raise it with --max-pixels)");
  }
  EXPECT_THROW(check_image_size("x.exr", 100000, 10), InputError);  // side
  EXPECT_THROW(check_nside("--nside", 4096), InputError);
  check_nside("--nside", 2048);
  EXPECT_THROW(check_light_count("--n", 1000001), InputError);
  check_light_count("--n", 1000000);
  Limits zero;
  zero.max_pixels = 0;
  EXPECT_THROW(set_limits(zero), InputError);
  EXPECT_EQ(limits().max_pixels, uint64_t(1) << 27);
}

TEST(ImageHeader, SizesFromHeadersAgreeWithTheDecoderOnRealFiles) {
  std::vector<std::string> files = {kJpeg, kPng};
  for (const auto& e : fs::directory_iterator(kData + "/calib-ocamcalib-omni-samples/KaidanOmni")) files.push_back(e.path().string());
  for (const std::string& path : files) {
    SCOPED_TRACE(path);
    if (!path.ends_with(".jpg") && !path.ends_with(".png")) continue;
    const auto header = read_image_header(path, read_bytes(path));
    ASSERT_TRUE(header.has_value());
    const CameraImage decoded = read_camera_image(path);
    EXPECT_EQ(header->width, decoded.width);
    EXPECT_EQ(header->height, decoded.height);
    EXPECT_LE(header->min_file_bytes, fs::file_size(path));
  }
}

TEST(ImageHeader, CraftedTiffPnmAndBmpHeadersGiveTheirSizes) {
  // Little- and big-endian TIFF with ImageWidth as SHORT and ImageLength as LONG.
  std::string le("II*\0\x08\0\0\0\x02\0", 10);
  le += std::string("\x00\x01\x03\x00\x01\x00\x00\x00\x34\x12\x00\x00", 12);
  le += std::string("\x01\x01\x04\x00\x01\x00\x00\x00\x78\x56\x00\x00", 12);
  auto h = read_image_header("le.tif", le);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->format, ImageFormat::Tiff);
  EXPECT_EQ(h->width, 0x1234);
  EXPECT_EQ(h->height, 0x5678);
  std::string be("MM\0*\0\0\0\x08\0\x02", 10);
  be += std::string("\x01\x00\x00\x03\x00\x00\x00\x01\x12\x34\x00\x00", 12);
  be += std::string("\x01\x01\x00\x04\x00\x00\x00\x01\x00\x00\x56\x78", 12);
  h = read_image_header("be.tif", be);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->width, 0x1234);
  EXPECT_EQ(h->height, 0x5678);

  h = read_image_header("a.ppm", "P6\n# comment\n300 200\n65535\n");
  ASSERT_TRUE(h);
  EXPECT_EQ(h->width, 300);
  EXPECT_EQ(h->height, 200);
  EXPECT_EQ(h->min_file_bytes, 300u * 200 * 3 * 2);

  std::string bmp(54, '\0');
  bmp[0] = 'B', bmp[1] = 'M';
  put_le32(bmp, 14, 40);
  put_le32(bmp, 18, 640);
  put_le32(bmp, 22, uint32_t(-480));  // top-down
  h = read_image_header("a.bmp", bmp);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->width, 640);
  EXPECT_EQ(h->height, 480);

  EXPECT_FALSE(read_image_header("a.webp", "RIFF\0\0\0\0WEBPVP8 "));
}

TEST(ImageHeader, PngMinimumSizeIsTheDeflateBoundOfItsPixelBytes) {
  const auto h = read_image_header(kPng, read_bytes(kPng));
  ASSERT_TRUE(h);
  EXPECT_EQ(h->min_file_bytes, 512u * 768 * 3 / 1032);
}

TEST(Readers, JpegClaiming16384SquaredIsRefusedFromItsHeader) {
  const std::string dir = temp_dir();
  const std::string path = dir + "forged.jpg";
  write_bytes(path, forged_jpeg(16384, 16384));
  ASSERT_LT(fs::file_size(path), 30000u);
  expect_fast_refusal([&] { read_camera_image(path); }, {path, "16384x16384", "over the limit of 134217728", "--max-pixels"});
  // With the limit raised, the size rule refuses it: 27.9 KB cannot hold 4 M Huffman blocks.
  RaisedLimits raised(uint64_t(1) << 30);
  expect_fast_refusal([&] { read_camera_image(path); }, {path, "cannot hold a 16384x16384 JPEG", "at least 524288"});
}

TEST(Readers, JpegClaimingMorePixelsThanItsBytesCanHoldIsRefusedWithinTheLimit) {
  // 8192x8192 is within the pixel limit; libjpeg would return 64 M grey pixels.
  const std::string path = temp_dir() + "forged.jpg";
  write_bytes(path, forged_jpeg(8192, 8192));
  expect_fast_refusal([&] { read_camera_image(path); }, {path, "cannot hold a 8192x8192 JPEG", "at least 131072"});
}

TEST(Readers, PngWithAnInvalidBitDepthIsOneLine) {
  std::string b = read_bytes(kPng);
  b[24] = 3;  // RGB allows 8 and 16
  const std::string path = temp_dir() + "depth3.png";
  write_bytes(path, b);
  expect_fast_refusal([&] { read_camera_image(path); }, {path, "bit depth 3 is not allowed for colour type 2"});
}

TEST(Readers, PngClaimingMorePixelsThanDeflateCanPackIsRefused) {
  std::string b = read_bytes(kPng);
  put_be32(b, 16, 65535);
  put_be32(b, 20, 2048);  // 134 M pixels, 402 MB of samples: at least 390 KB at deflate's best
  const std::string path = temp_dir() + "big.png";
  write_bytes(path, b.substr(0, 200000));
  expect_fast_refusal([&] { read_camera_image(path); }, {path, "cannot hold a 65535x2048 PNG"});
}

TEST(Readers, UnknownCameraImageFormatsAreRefusedBeforeDecoding) {
  const std::string path = temp_dir() + "a.webp";
  write_bytes(path, std::string("RIFF\x10\0\0\0WEBPVP8 ", 16));
  expect_fast_refusal([&] { read_camera_image(path); }, {path, "unsupported camera image format"});
}

TEST(Readers, RgbeHeaderOf16384SquaredIn120BytesIsRefusedBeforeAllocating) {
  const std::string dir = temp_dir();
  std::string b = "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 16384 +X 16384\n";
  b += std::string(120 - b.size(), '\x02');
  const std::string path = dir + "huge.hdr";
  write_bytes(path, b);
  expect_fast_refusal([&] { read_envmap(path); }, {path, "16384x16384", "--max-pixels"});
  RaisedLimits raised(uint64_t(1) << 30);
  expect_fast_refusal([&] { read_envmap(path); }, {path, "cannot hold 16384 scanlines"});
}

TEST(Readers, PfmHeaderOf16384SquaredIsRefusedBeforeAllocating) {
  const std::string path = temp_dir() + "huge.pfm";
  write_bytes(path, "PF\n16384 16384\n-1.0\n" + std::string(100, '\0'));
  expect_fast_refusal([&] { read_envmap(path); }, {path, "16384x16384", "--max-pixels"});
  RaisedLimits raised(uint64_t(1) << 30);
  expect_fast_refusal([&] { read_envmap(path); }, {path, "truncated file"});
}

// A small valid EXR written by the project, and the offset of an attribute's size field.
std::string small_exr(const std::string& dir) {
  EnvMap map = make_latlong(8, 4);
  std::fill(map.rgb.begin(), map.rgb.end(), 1.0f);
  write_envmap(dir + "small.exr", map);
  return read_bytes(dir + "small.exr");
}
size_t attribute_size_at(const std::string& exr, const std::string& name, const std::string& type) {
  const size_t at = exr.find(name + std::string(1, '\0') + type + std::string(1, '\0'));
  EXPECT_NE(at, std::string::npos) << name;
  return at + name.size() + type.size() + 2;
}

TEST(Readers, ExrDataWindowOf16384SquaredIsRefusedBeforeOpenExrReadsIt) {
  const std::string dir = temp_dir();
  std::string b = small_exr(dir);
  const size_t value = attribute_size_at(b, "dataWindow", "box2i") + 4;
  put_le32(b, value + 8, 16383);   // xMax
  put_le32(b, value + 12, 16383);  // yMax
  const std::string path = dir + "window.exr";
  write_bytes(path, b);
  expect_fast_refusal([&] { read_envmap(path); }, {path, "data window 16384x16384", "--max-pixels"});
  RaisedLimits raised(uint64_t(1) << 30);
  expect_fast_refusal([&] { read_envmap(path); }, {path, "offset table of 1024 chunks"});  // ZIP: 16 lines a chunk
}

TEST(Readers, ExrStringAttributeClaiming2GiBIsRefusedBeforeOpenExrAllocatesIt) {
  const std::string dir = temp_dir();
  std::string b = small_exr(dir);
  put_le32(b, attribute_size_at(b, "lightprobe.units", "string"), 0x7fffffff);
  const std::string path = dir + "attribute.exr";
  write_bytes(path, b);
  expect_fast_refusal([&] { read_envmap(path); }, {path, "attribute 'lightprobe.units' claims 2147483647 bytes"});
  // The unmodified file still reads.
  EXPECT_EQ(read_envmap(dir + "small.exr").width, 8);
}

TEST(Readers, MapWithoutLayoutThatIsNoMapShapeIsRefusedUnlessTheLayoutIsGiven) {
  const std::string dir = temp_dir();
  RgbImage square;
  square.width = square.height = 300;
  square.rgb.assign(3 * 300 * 300, 0.5f);
  for (const char* ext : {".exr", ".hdr", ".pfm"}) {
    SCOPED_TRACE(ext);
    const std::string path = dir + "photo" + ext;
    write_rgb_image(path, square);  // records no layout
    expect_fast_refusal([&] { read_envmap(path); }, {path, "no layout recorded", "300x300", "--layout"});
    ReadMapOptions given;
    given.layout = Layout::Hemisphere;
    EXPECT_EQ(read_envmap(path, given).layout, Layout::Hemisphere);
    EXPECT_EQ(read_rgb_image(path).width, 300);
  }
  // The shapes CONVENTIONS.md gives a layout by are still inferred.
  const std::pair<int, int> shapes[] = {{64, 32}, {360, 90}, {4, 48}};
  const Layout inferred[] = {Layout::LatLong, Layout::Hemisphere, Layout::Healpix};
  for (int k = 0; k < 3; ++k) {
    RgbImage img;
    img.width = shapes[k].first;
    img.height = shapes[k].second;
    img.rgb.assign(3 * size_t(img.width) * size_t(img.height), 0.25f);
    write_rgb_image(dir + "shape.pfm", img);
    EXPECT_EQ(read_envmap(dir + "shape.pfm").layout, inferred[k]) << img.width << "x" << img.height;
  }
}

}  // namespace
}  // namespace lp
