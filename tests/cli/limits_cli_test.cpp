// Size-like flags and crafted inputs against core/limits.h as a user sees them: exit 2, one
// line naming the flag (or the file) and the limit, nothing written, refused when parsed
// (before any input is read or any output allocated); the global --max-pixels and
// --max-lights move the limits.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "tests/cli/cli_run.h"

namespace fs = std::filesystem;

using namespace lp::cli_test;

namespace {

// A refusal of `needle` with `limit` in the message and `output` not written.
void expect_refused(const CliRun& r, const std::string& needle, const std::string& limit, const fs::path& output) {
  expect_one_line_error(r, needle);
  EXPECT_NE(r.err.find(limit), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(output)) << output;
}

// A small latlong map made once for the tests that need an input.
std::string small_map() {
  static const std::string path = [] {
    const fs::path p = scratch() / "small.exr";
    const CliRun r = lightprobe("synth scene --size 64x32 -o " + p.string());
    EXPECT_EQ(r.code, 0) << r.err;
    return p.string();
  }();
  return path;
}

void write_file(const fs::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), std::streamsize(bytes.size()));
}

}  // namespace

TEST(LimitsCli, ConvertRefusesTargetSizesBeyondTheLimitBeforeReading) {
  const fs::path out = scratch() / "big.exr";
  expect_refused(lightprobe("convert " + small_map() + " " + out.string() + " --size 40000x20000"), "--size",
                 "over the limit of 134217728 (raise it with --max-pixels)", out);
  expect_refused(lightprobe("convert " + small_map() + " " + out.string() + " --size 100000x50000"), "--size",
                 "65535 pixels a side", out);
  expect_refused(lightprobe("convert " + small_map() + " " + out.string() + " --layout healpix --nside 8192"),
                 "--nside", "limit of nside 2048", out);
  // Checked before the input is read: a missing input is not what is reported.
  expect_refused(lightprobe("convert missing.exr " + out.string() + " --size 40000x20000"), "--size", "--max-pixels", out);
}

TEST(LimitsCli, SynthUnwrapAndStreamSizesAreCheckedToo) {
  const fs::path out = scratch() / "s.exr";
  expect_refused(lightprobe("synth scene --size 40000x20000 -o " + out.string()), "--size", "--max-pixels", out);
  expect_refused(lightprobe("synth scene --layout healpix --nside 8192 -o " + out.string()), "--nside", "nside 2048", out);
  expect_refused(lightprobe("synth probe scene --type mirrorball --size 20000x20000 -o " + out.string()), "--size",
                 "--max-pixels", out);
  expect_refused(lightprobe("synth sequence --frames 1000000 -o " + (scratch() / "seq").string()), "--frames",
                 "limit of 10000", scratch() / "seq");
  expect_refused(lightprobe("probe unwrap " + small_map() + " --type mirrorball --layout latlong --size 40000x20000 -o " +
                            out.string()),
                 "--size", "--max-pixels", out);
  expect_refused(lightprobe("stream --source replay:" + scratch().string() + " --n 10000000 --duration 1"), "--n",
                 "limit of 1000000", out);
}

TEST(LimitsCli, SampleRefusesMoreLightsThanTheLimitForEveryMethod) {
  const fs::path out = scratch() / "lights.json";
  for (const char* method : {"pharr", "hemigon", "q2tree", "mediancut"}) {
    SCOPED_TRACE(method);
    expect_refused(lightprobe("sample " + small_map() + " --method " + method + " --n 10000000 -o " + out.string()),
                   "--n", "10000000 lights is over the limit of 1000000 (raise it with --max-lights)", out);
  }
  expect_refused(lightprobe("sample " + small_map() + " --method q2tree --q2-nside 8192 -o " + out.string()),
                 "--q2-nside", "nside 2048", out);
  expect_refused(lightprobe("eval sampling " + small_map() + " --n 16,2000000 -o " + (scratch() / "ev").string()),
                 "--n", "limit of 1000000", scratch() / "ev");
}

TEST(LimitsCli, TablesRefuseALutBeyondTheLimit) {
  const fs::path out = scratch() / "tables.json";
  expect_refused(lightprobe("tables scene --lut 100000 -o " + out.string()), "--lut", "limit of 1024", out);
  expect_refused(lightprobe("tables scene --lut 8 --regions 1000 -o " + out.string()), "--regions", "384", out);
}

TEST(LimitsCli, MaxPixelsAndMaxLightsMoveTheLimitsBothWays) {
  const fs::path out = scratch() / "moved.exr";
  // 64x32 = 2048 pixels: over a limit of 1000, under one of 3000.
  expect_refused(lightprobe("--max-pixels 1000 synth scene --size 64x32 -o " + out.string()), "--size",
                 "over the limit of 1000", out);
  CliRun ok = lightprobe("--max-pixels 3000 synth scene --size 64x32 -o " + out.string());
  EXPECT_EQ(ok.code, 0) << ok.err;
  EXPECT_TRUE(fs::exists(out));
  // Readers obey it too: the map just written is over a limit of 1000.
  expect_one_line_error(lightprobe("info " + out.string() + " --max-pixels 1000"), out.string());
  const fs::path lights = scratch() / "moved.json";
  expect_refused(lightprobe("sample " + small_map() + " --n 20 --max-lights 10 -o " + lights.string()), "--n",
                 "limit of 10", lights);
  CliRun more = lightprobe("sample " + small_map() + " --n 20 --max-lights 20 -o " + lights.string());
  EXPECT_EQ(more.code, 0) << more.err;
  expect_one_line_error(lightprobe("--max-pixels 0 info " + out.string()), "--max-pixels");
}

TEST(LimitsCli, ForgedCameraImagesAreRefusedInOneLineAndNothingIsWritten) {
  const fs::path dir = scratch() / "forged";
  fs::create_directories(dir);
  // A 27.9 KB JPEG whose frame header says 16384x16384 (the SOF0 segment patched).
  std::string jpeg = slurp(shared("calib-opencv-stereo-9x6/left01.jpg"));
  size_t sof = 2;
  while (static_cast<unsigned char>(jpeg[sof + 1]) != 0xC0)
    sof += 2 + (size_t(static_cast<unsigned char>(jpeg[sof + 2])) << 8 | static_cast<unsigned char>(jpeg[sof + 3]));
  for (size_t k : {5, 6, 7, 8}) jpeg[sof + k] = k % 2 ? '\x40' : '\x00';
  write_file(dir / "forged.jpg", jpeg);
  const fs::path png_out = dir / "preview.png";
  expect_refused(lightprobe("preview " + (dir / "forged.jpg").string() + " -o " + png_out.string()),
                 (dir / "forged.jpg").string(), "16384x16384", png_out);
  // A PNG with a bit depth its colour type does not allow: libpng's four lines are one.
  std::string png = slurp(shared("hdr-memorial-debevec/memorial0064.png"));
  png[24] = 3;
  write_file(dir / "depth.png", png);
  expect_refused(lightprobe("preview " + (dir / "depth.png").string() + " -o " + png_out.string()),
                 (dir / "depth.png").string(), "bit depth 3", png_out);
}

TEST(LimitsCli, AnImageOfNoMapShapeIsNotSampledUnlessItsLayoutIsGiven) {
  // A fused photograph: 300x300, no layout recorded.
  const fs::path photo = scratch() / "ball.exr", out = scratch() / "photo.json";
  ASSERT_EQ(lightprobe("synth probe scene --type mirrorball --size 300x300 -o " + photo.string()).code, 0);
  const CliRun r = lightprobe("sample " + photo.string() + " --method pharr --n 16 -o " + out.string());
  expect_refused(r, photo.string(), "no layout recorded and 300x300 is not the shape of one", out);
  EXPECT_NE(r.err.find("--type mirrorball for a mirror ball, --type fisheye --fov 360 for an angular map"),
            std::string::npos)
      << r.err;
  const CliRun given = lightprobe("sample " + photo.string() + " --layout hemisphere --method pharr --n 16 -o " + out.string());
  EXPECT_EQ(given.code, 0) << given.err;
}
