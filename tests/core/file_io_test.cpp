#include "core/file_io.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/image_io.h"
#include "core/map_sequence.h"
#include "core/picture_io.h"
#include "core/tonemap.h"

namespace fs = std::filesystem;

namespace lp {
namespace {

std::string temp_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path dir = fs::path(::testing::TempDir()) / "lightprobe_file_io" / info->name();
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir.string() + "/";
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(FileIo, TextFilesReadBackByteForByte) {
  const std::string dir = temp_dir();
  std::string bytes = "a,b\r\n1,2\n";
  bytes += std::string(1, '\0') + std::string(100000, 'x');  // binary and longer than one read
  write_file_atomically(dir + "t.csv", bytes);
  EXPECT_EQ(read_text_file(dir + "t.csv"), bytes);
  write_file_atomically(dir + "empty.txt", "");
  EXPECT_EQ(read_text_file(dir + "empty.txt"), "");
}

TEST(FileIo, UnreadableOrOversizedTextFilesAreOneLineErrorsNamingTheFile) {
  const std::string dir = temp_dir();
  const std::string missing = error_of([&] { read_text_file(dir + "none.csv", "the readings file"); });
  EXPECT_NE(missing.find(dir + "none.csv: cannot open the readings file: "), std::string::npos) << missing;
  const std::string folder = error_of([&] { read_text_file(dir); });
  EXPECT_NE(folder.find("cannot open: Is a directory"), std::string::npos) << folder;
  write_file_atomically(dir + "big.json", std::string(1001, ' '));
  EXPECT_EQ(read_text_file(dir + "big.json", "", 1001).size(), 1001u);
  const std::string big = error_of([&] { read_text_file(dir + "big.json", "", 1000); });
  EXPECT_EQ(big, dir + "big.json: larger than 1000 bytes");
}

TEST(FileIo, ExtensionsAreTheFileNamesLowerCased) {
  EXPECT_EQ(lower_extension("a/b/Probe.EXR"), ".exr");
  EXPECT_EQ(lower_extension("dir.d/probe"), "");
  EXPECT_EQ(lower_extension("probe"), "");
  EXPECT_EQ(lower_extension("x.tar.GZ"), ".gz");
  EXPECT_TRUE(is_radiance_file("m/map.HDR"));
  EXPECT_TRUE(is_radiance_file("map.pfm"));
  EXPECT_FALSE(is_radiance_file("map.png"));
  EXPECT_TRUE(is_camera_image_file("IMG_0001.JPG"));
  EXPECT_TRUE(is_camera_image_file("f.tiff"));
  EXPECT_FALSE(is_camera_image_file("f.exr"));
  EXPECT_FALSE(is_camera_image_file("exr.d/f"));
}

// The one picture encoder (core/picture_io.h), read back through read_camera_image.

// Capture tools number frames without padding: frame_10 sorted before frame_2, and a
// folder's sequence was replayed scrambled.
TEST(FileIo, FrameNamesSortByTheirNumbers) {
  std::vector<std::string> names = {"frame_10.png", "frame_2.png", "frame_1.png", "frame_02.png", "b.exr",
                                    "frame_100.png", "a9.exr", "a10.exr", "frame_.png", "cam1_frame_3.png", "cam1_frame_20.png"};
  std::sort(names.begin(), names.end(), frame_name_less);
  EXPECT_EQ(names, (std::vector<std::string>{"a9.exr", "a10.exr", "b.exr", "cam1_frame_3.png", "cam1_frame_20.png",
                                             "frame_.png", "frame_1.png", "frame_02.png", "frame_2.png",
                                             "frame_10.png", "frame_100.png"}));
  EXPECT_FALSE(frame_name_less("x", "x"));
  EXPECT_TRUE(frame_name_less("frame_000", "frame_001")) << "padded names keep their order";
  EXPECT_TRUE(frame_name_less("frame_99999999999999999999", "frame_100000000000000000000")) << "runs longer than 64 bits";
  // A folder of maps (sample, probe unwrap, eval temporal) is read in that order.
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "lightprobe_frame_order";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  for (const char* name : {"map_10.exr", "map_2.exr", "map_1.exr"}) std::ofstream(dir / name) << "";
  const MapSequence seq = find_map_sequence({dir.string()});
  ASSERT_EQ(seq.files.size(), 3u);
  EXPECT_EQ(std::filesystem::path(seq.files[0]).filename(), "map_1.exr");
  EXPECT_EQ(std::filesystem::path(seq.files[1]).filename(), "map_2.exr");
  EXPECT_EQ(std::filesystem::path(seq.files[2]).filename(), "map_10.exr");
  std::filesystem::remove_all(dir);
}

TEST(PictureEncoder, ServedPngsAreTheBytesOfTheWrittenFile) {
  const std::string dir = temp_dir();
  std::vector<float> rgb;
  for (int i = 0; i < 4 * 3 * 3; ++i) rgb.push_back(float(i) / 36.0f);
  write_display_image(dir + "p.png", 4, 3, rgb);
  const std::string served = encode_display_png(4, 3, rgb);
  EXPECT_EQ(served.substr(1, 3), "PNG");
  EXPECT_EQ(served, read_text_file(dir + "p.png"));
  const CameraImage back = read_camera_image(dir + "p.png");
  for (size_t i = 0; i < rgb.size(); ++i) EXPECT_FLOAT_EQ(back.rgb[i] * 255, srgb_code(rgb[i])) << i;
}

TEST(PictureEncoder, CodeImagesStoreTheirCodesWithoutATransferCurve) {
  const std::string dir = temp_dir();
  const std::vector<uint16_t> codes = {0, 1, 2, 100, 127, 128, 200, 254, 255, 3, 77, 250, 9, 90, 190, 0, 255, 1};
  for (int depth : {8, 16}) {
    const int scale = depth == 8 ? 1 : 257;  // 16-bit: the same codes spread over 0..65535
    std::vector<uint16_t> rgb;
    for (uint16_t c : codes) rgb.push_back(uint16_t(c * scale));
    for (const char* ext : {".png", ".tif"}) {
      const std::string path = dir + "c" + std::to_string(depth) + ext;
      write_file_atomically(path, encode_rgb_codes(path, 3, 2, depth, rgb));
      const CameraImage back = read_camera_image(path);
      ASSERT_EQ(back.bit_depth, depth) << path;
      ASSERT_EQ(back.rgb.size(), rgb.size());
      const double max = depth == 8 ? 255.0 : 65535.0;
      for (size_t i = 0; i < rgb.size(); ++i) EXPECT_EQ(std::lround(back.rgb[i] * max), rgb[i]) << path << " " << i;
    }
  }
}

TEST(PictureEncoder, UnencodableRequestsNameTheFile) {
  const std::vector<uint16_t> grey = {128, 128, 128};
  EXPECT_EQ(error_of([&] { encode_rgb_codes("out/c.xyz", 1, 1, 8, grey); }), "out/c.xyz: cannot encode as .xyz");
  EXPECT_EQ(error_of([&] { encode_rgb_codes("c.png", 1, 1, 12, grey); }), "c.png: bit depth must be 8 or 16");
  EXPECT_EQ(error_of([&] { encode_rgb_codes("c.png", 2, 1, 8, grey); }), "c.png: image buffer does not match its size");
  EXPECT_EQ(error_of([&] { encode_display_image("c.bmp", 1, 1, {0.5f, 0.5f, 0.5f}); }),
            "c.bmp: unsupported display image format '.bmp' (expected .png or .jpg)");
}

}  // namespace
}  // namespace lp
