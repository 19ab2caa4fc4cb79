#include "probe/synthetic_probe.h"

#include <gtest/gtest.h>

#include <cmath>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "core/error.h"
#include "core/image_io.h"
#include "core/json_file.h"
#include "eval/synthetic_scene.h"

namespace lp {
namespace {

namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path d = fs::temp_directory_path() / ("lp_synthetic_probe_" + std::to_string(::getpid())) / name;
  fs::remove_all(d);
  return d;
}

// A jittered sequence on disk is the track's balls, each frame rendered with seed + frame.
TEST(SyntheticProbe, SequenceFramesAndTruthFollowTheJitteredTrack) {
  const EnvMap world = render_scene(describe_scene(), Layout::LatLong, 128, 64);
  SyntheticProbeOptions o;
  o.width = o.height = 48;
  o.frames = 3;
  o.jitter_px = 2;
  o.noise_relative = 0.01;
  o.seed = 5;
  const fs::path dir = scratch("sequence");
  const nlohmann::json truth = write_synthetic_probe(world, "scene", o, dir.string());
  EXPECT_EQ(read_json_file((dir / "truth.json").string()), truth);
  EXPECT_EQ(truth["input"], "scene");
  const auto track = jittered_track({24, 24, 0.4 * 48}, 3, 2, 5);
  ASSERT_EQ(truth["per_frame"].size(), 3u);
  for (int f = 0; f < 3; ++f) {
    EXPECT_DOUBLE_EQ(truth["per_frame"][f]["ball"][0].get<double>(), track[size_t(f)].cx);
    EXPECT_DOUBLE_EQ(truth["per_frame"][f]["ball"][1].get<double>(), track[size_t(f)].cy);
  }
  RenderBallOptions ro;
  ro.noise_relative = 0.01;
  ro.seed = 6;  // frame 1
  const RgbImage expected = render_mirror_ball(world, track[1], MirrorBallCamera{}, 48, 48, ro);
  EXPECT_EQ(read_rgb_image((dir / "frame_0001.exr").string()).rgb, expected.rgb);
  fs::remove_all(dir.parent_path());
}

TEST(SyntheticProbe, RefusesBeforeWritingAnything) {
  const EnvMap world = render_scene(describe_scene(), Layout::LatLong, 64, 32);
  SyntheticProbeOptions o;
  o.type = "fisheye";
  o.frames = 2;
  const fs::path dir = scratch("refused");
  EXPECT_THROW(write_synthetic_probe(world, "scene", o, dir.string()), InputError);
  o.type = "cube";
  o.frames = 1;
  EXPECT_THROW(write_synthetic_probe(world, "scene", o, (dir / "x.exr").string()), InputError);
  // The other type's options: the fisheye render took --noise and wrote the same noiseless image.
  auto message = [&](const SyntheticProbeOptions& bad) {
    try {
      write_synthetic_probe(world, "scene", bad, (dir / "x.exr").string());
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("(accepted)");
  };
  SyntheticProbeOptions fisheye;
  fisheye.type = "fisheye";
  fisheye.noise_relative = 0.5;
  EXPECT_NE(message(fisheye).find("--noise applies to --type mirrorball"), std::string::npos);
  SyntheticProbeOptions ball;
  ball.fov_deg = 90;
  EXPECT_NE(message(ball).find("--fov applies to --type fisheye"), std::string::npos);
  ball = {};
  ball.noise_relative = INFINITY;
  EXPECT_NE(message(ball).find("--noise must be a relative noise"), std::string::npos);
  ball = {};
  ball.jitter_px = 3;
  EXPECT_NE(message(ball).find("give --frames"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir));
  fs::remove_all(dir.parent_path());
}

}  // namespace
}  // namespace lp
