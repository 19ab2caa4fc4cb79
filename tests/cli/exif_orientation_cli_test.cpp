// Camera images whose EXIF Orientation is noise, as a camera pointing up records it: a
// bracket's frames that disagree, and a fisheye sky photo. The pixels as stored are what
// the sensor saw; each file here is a JPEG with an Orientation spliced in, its pixels
// unchanged, and the result must be that of the same JPEG without it.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/image_io.h"
#include "tests/cli/cli_run.h"

namespace lp::cli_test {
namespace {

// `from` (a PNG) written as a JPEG at `to`, and the same JPEG with `orientation` spliced in
// at `tagged`.
void jpeg_and_tagged(const std::string& from, const fs::path& to, const fs::path& tagged, char orientation) {
  const CameraImage c = read_camera_image(from);
  write_display_image(to.string(), c.width, c.height, c.rgb);
  std::ofstream(tagged.string(), std::ios::binary) << with_exif_orientation(slurp(to), orientation);
}

void expect_same_map(const fs::path& a, const fs::path& b) {
  const RgbImage x = read_rgb_image(a.string()), y = read_rgb_image(b.string());  // a fused photo has no layout
  ASSERT_EQ(x.width, y.width);
  ASSERT_EQ(x.height, y.height);
  EXPECT_TRUE(x.rgb == y.rgb) << a << " and " << b << " differ";
}

// One frame of three tagged upside down: the bracket had merged it turned 180 degrees against
// the other two (the fused map's mean error 0.17 against 0.02 of JPEG noise, measured).
TEST(ExifOrientationCli, ABracketWhoseFramesDisagreeIsReadAsStored) {
  const fs::path dir = fresh_dir("exif_bracket");
  const std::string memorial = shared("hdr-memorial-debevec/memorial00");
  jpeg_and_tagged(memorial + "63.png", dir / "a.jpg", dir / "a_unused.jpg", 1);
  jpeg_and_tagged(memorial + "64.png", dir / "b.jpg", dir / "b_upside_down.jpg", 3);
  jpeg_and_tagged(memorial + "65.png", dir / "c.jpg", dir / "c_unused.jpg", 1);
  const std::string times = " --exposure-times 8,4,2 -o ";
  const CliRun plain = lightprobe("hdr fuse " + (dir / "a.jpg").string() + " " + (dir / "b.jpg").string() + " " +
                                  (dir / "c.jpg").string() + times + (dir / "plain.exr").string());
  const CliRun mixed = lightprobe("hdr fuse " + (dir / "a.jpg").string() + " " + (dir / "b_upside_down.jpg").string() +
                                  " " + (dir / "c.jpg").string() + times + (dir / "mixed.exr").string());
  ASSERT_EQ(plain.code, 0) << plain.err;
  ASSERT_EQ(mixed.code, 0) << mixed.err;
  EXPECT_NE(mixed.err.find("the frames' EXIF Orientation disagree (1, 3, 1): one camera did not turn between the frames "
                           "of a bracket, so they are read as stored"),
            std::string::npos)
      << mixed.err;
  expect_same_map(dir / "plain.exr", dir / "mixed.exr");
}

// A fisheye sky photo tagged upside down had come out turned 180 degrees in azimuth.
TEST(ExifOrientationCli, AFisheyeIsUnwrappedInItsSensorsFrame) {
  const fs::path dir = fresh_dir("exif_fisheye");
  const fs::path sky = dir / "sky.exr";
  ASSERT_EQ(lightprobe("synth probe scene --type fisheye --fov 190 --size 96x96 -o " + sky.string()).code, 0);
  const RgbImage r = read_rgb_image(sky.string());
  std::vector<float> codes(r.rgb.size());
  for (size_t i = 0; i < codes.size(); ++i) codes[i] = std::min(1.0f, r.rgb[i] / 4);  // written sRGB-encoded
  write_display_image((dir / "sky.png").string(), r.width, r.height, codes);
  jpeg_and_tagged((dir / "sky.png").string(), dir / "sky.jpg", dir / "sky_upside_down.jpg", 3);
  const std::string args = " --type fisheye --fov 190 --size 64x32 -o ";
  const CliRun plain = lightprobe("probe unwrap " + (dir / "sky.jpg").string() + args + (dir / "plain.exr").string());
  const CliRun tagged =
      lightprobe("probe unwrap " + (dir / "sky_upside_down.jpg").string() + args + (dir / "tagged.exr").string());
  ASSERT_EQ(plain.code, 0) << plain.err;
  ASSERT_EQ(tagged.code, 0) << tagged.err;
  EXPECT_NE(tagged.err.find("its EXIF Orientation (3) is not applied: a fisheye is unwrapped in its sensor's frame"),
            std::string::npos)
      << tagged.err;
  expect_same_map(dir / "plain.exr", dir / "tagged.exr");
}

// A fisheye bracket whose frames all carry one tag, upside down: hdr fuse shows it as the
// tags say (it cannot know it is a fisheye) and records the turn; probe unwrap --type fisheye
// turns it back to the sensor's frame. It had been unwrapped 180 degrees off in azimuth.
TEST(ExifOrientationCli, AFisheyeBracketFusedTurnedIsUnwrappedInItsSensorsFrame) {
  const fs::path dir = fresh_dir("exif_fisheye_bracket");
  const fs::path sky = dir / "sky.exr";
  ASSERT_EQ(lightprobe("synth probe scene --type fisheye --fov 190 --size 96x64 -o " + sky.string()).code, 0);
  const RgbImage r = read_rgb_image(sky.string());
  std::string plain, tagged;
  for (const int k : {0, 1, 2}) {
    std::vector<float> codes(r.rgb.size());
    for (size_t i = 0; i < codes.size(); ++i) codes[i] = std::min(1.0f, r.rgb[i] * float(1 << (3 * k)) / 64);
    const fs::path png = dir / ("f" + std::to_string(k) + ".png");
    write_display_image(png.string(), r.width, r.height, codes);
    const fs::path a = dir / ("f" + std::to_string(k) + ".jpg"), b = dir / ("f" + std::to_string(k) + "_up.jpg");
    jpeg_and_tagged(png.string(), a, b, 3);
    plain += a.string() + " ", tagged += b.string() + " ";
  }
  // One response for both: recovered from the plain frames (the tagged ones are the same pixels).
  const fs::path response = dir / "response.json";
  const std::string times = "--exposure-times 1,8,64 ";
  ASSERT_EQ(lightprobe("hdr response " + plain + times + "-o " + response.string()).code, 0);
  const std::string fuse = "hdr fuse " + times + "--response " + response.string() + " ";
  ASSERT_EQ(lightprobe(fuse + plain + "-o " + (dir / "plain.exr").string()).code, 0);
  const CliRun fused = lightprobe(fuse + tagged + "-o " + (dir / "tagged.exr").string());
  ASSERT_EQ(fused.code, 0) << fused.err;
  const RgbImage shown = read_rgb_image((dir / "tagged.exr").string());
  EXPECT_EQ(shown.orientation, 3);  // recorded in the file
  EXPECT_EQ(turned_back_to_sensor(shown).rgb, read_rgb_image((dir / "plain.exr").string()).rgb);

  const std::string unwrap = " --type fisheye --fov 190 --size 64x32 -o ";
  ASSERT_EQ(lightprobe("probe unwrap " + (dir / "plain.exr").string() + unwrap + (dir / "plain_map.exr").string()).code, 0);
  const CliRun back = lightprobe("probe unwrap " + (dir / "tagged.exr").string() + unwrap + (dir / "tagged_map.exr").string());
  ASSERT_EQ(back.code, 0) << back.err;
  EXPECT_NE(back.err.find("fused turned by its frames' EXIF Orientation (3); turned back"), std::string::npos) << back.err;
  expect_same_map(dir / "plain_map.exr", dir / "tagged_map.exr");
}

}  // namespace
}  // namespace lp::cli_test
