// eval calib as a library call, on chessboard views rendered through a known fisheye
// (calib/synthetic_boards.h): our calibration and OpenCV's alone on the same corners.
#include <unistd.h>  // getpid: ctest runs each test in its own process, at once

#include "eval/calib_eval.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>

#include <fmt/format.h>

#include "calib/projection_difference.h"
#include "calib/synthetic_boards.h"
#include "core/error.h"
#include "core/image_io.h"

namespace lp {
namespace {

namespace fs = std::filesystem;

SyntheticBoardsOptions boards_options() {
  SyntheticBoardsOptions o;
  o.views = 5;
  o.board = BoardSpec{7, 5, 30};
  o.camera = CameraModel{lens_type_name(LensType::KannalaBrandt), {180, 180, 319.5, 239.5, 0.02, -0.005, 0, 0}, 640, 480};
  return o;
}

const EvalCalibReport& report() {
  static const EvalCalibReport r = [] {
    const fs::path dir = fs::temp_directory_path() / ("lightprobe_calib_eval_test_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir / "views");
    const SyntheticBoardsOptions bo = boards_options();
    const SyntheticBoards b = synthesize_boards(bo);
    EvalCalibOptions o;
    o.board = bo.board;
    o.output_dir = (dir / "out").string();
    for (size_t i = 0; i < b.images.size(); ++i) {
      o.images.push_back((dir / "views" / fmt::format("board_{:02d}.png", i)).string());
      write_display_image(o.images.back(), b.images[i].width, b.images[i].height, b.images[i].rgb);
    }
    return evaluate_calib(o);
  }();
  return r;
}

// Rendered with little noise (0.01) and blur (0.7 px) through a known Kannala-Brandt lens:
// every view's board is found; our choice fits the corners to a tenth of a pixel and agrees
// with the true lens within 60 deg of the axis (where the boards are); each of our
// single solves starts from its OpenCV peer and refines it, so fits at least as well.
TEST(CalibEval, ComparesOnRenderedBoardsAgainstTheTrueLens) {
  const EvalCalibReport& r = report();
  ASSERT_TRUE(r.comparison);
  EXPECT_TRUE(r.sweep.empty());
  const CalibComparison& c = *r.comparison;
  std::printf("%s", r.summary().c_str());
  EXPECT_EQ(c.views, 5);
  EXPECT_LT(c.ours.model.rms_reprojection_px, 0.15);
  const CameraModel truth = boards_options().camera;
  std::vector<uint8_t> mask(size_t(truth.width) * truth.height, 0);
  for (int y = 0; y < truth.height; ++y)
    for (int x = 0; x < truth.width; ++x) {
      const auto d = unproject(truth, {double(x), double(y)});
      mask[size_t(y) * truth.width + x] = d && d->z > std::cos(60 * M_PI / 180);
    }
  const ProjectionDiff pd = projection_difference(c.ours.model, truth, mask, 8);
  std::printf("  chosen %s against the true lens within 60 deg: %.3f px RMS over %d samples\n", c.ours.selected.c_str(),
              pd.rms_px, pd.samples);
  EXPECT_GT(pd.samples, 1000);
  EXPECT_LT(pd.rms_px, 0.5);
  ASSERT_EQ(c.peers.size(), 4u);
  ASSERT_EQ(c.speed.size(), 4u);
  for (const CalibComparison::Speed& s : c.speed) {
    ASSERT_TRUE(std::isfinite(s.ours_rms_px) && std::isfinite(s.peer_rms_px)) << s.model;
    EXPECT_LE(s.ours_rms_px, s.peer_rms_px + 1e-6) << s.model;
    EXPECT_GT(s.model_command_seconds, 0) << s.model;
  }
  // The files: a row per solver and candidate, a row per model pair.
  const nlohmann::json j = r.to_json();
  EXPECT_EQ(j["compare"].size(), 5u);  // ours + four OpenCV solvers
  EXPECT_EQ(j["speed"].size(), 4u);
  EXPECT_FALSE(j.contains("sweep"));
  EXPECT_TRUE(fs::exists(fs::path(r.output_dir) / "calib_compare.csv"));
  EXPECT_TRUE(fs::exists(fs::path(r.output_dir) / "calib_speed.csv"));
}

TEST(CalibEval, NothingToDoIsRefused) {
  EvalCalibOptions o;
  EXPECT_THROW(validate(o), InputError);
  o.sweep = true;
  o.board.cols = 1;
  EXPECT_THROW(validate(o), InputError);
}

}  // namespace
}  // namespace lp
