#include "calib/synthetic_boards.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <unistd.h>
#include <vector>

#include "calib/board_detect.h"
#include "core/error.h"
#include "core/image_io.h"
#include "core/json_file.h"

namespace lp {
namespace {

using Corners = std::vector<std::array<double, 2>>;

// Local lenses, independent of calib/camera_model.cpp: Kannala-Brandt and pinhole.
struct Kb {
  double fx, fy, cx, cy, k1, k2, k3, k4;
  double theta_d(double t) const {
    const double t2 = t * t;
    return t * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))));
  }
  std::optional<Pixel> project(Vec3 d) const {
    const double rho = std::hypot(d.x, d.y);
    const double t = std::atan2(rho, d.z);
    if (t > 0.999 * M_PI) return std::nullopt;
    const double td = theta_d(t);
    const double cx_ = rho > 0 ? d.x / rho : 0, sy = rho > 0 ? d.y / rho : 0;
    return Pixel{fx * td * cx_ + cx, fy * td * sy + cy};
  }
  std::optional<Vec3> unproject(Pixel p) const {
    const double mx = (p.x - cx) / fx, my = (p.y - cy) / fy;
    const double td = std::hypot(mx, my);
    if (td < 1e-12) return Vec3{0, 0, 1};
    double t = td;
    for (int i = 0; i < 30; ++i) {
      const double h = 1e-7;
      const double f = theta_d(t) - td, df = (theta_d(t + h) - theta_d(t - h)) / (2 * h);
      if (!(df > 0)) return std::nullopt;
      t -= f / df;
    }
    if (!(t >= 0 && t < M_PI) || std::fabs(theta_d(t) - td) > 1e-9) return std::nullopt;
    return Vec3{std::sin(t) * mx / td, std::sin(t) * my / td, std::cos(t)};
  }
  LensFunctions lens() const {
    return {[this](Vec3 d) { return project(d); }, [this](Pixel p) { return unproject(p); }};
  }
};

struct Pinhole {
  double fx, fy, cx, cy;
  LensFunctions lens() const {
    return {[this](Vec3 d) -> std::optional<Pixel> {
              if (d.z <= 1e-9) return std::nullopt;
              return Pixel{fx * d.x / d.z + cx, fy * d.y / d.z + cy};
            },
            [this](Pixel p) -> std::optional<Vec3> {
              return normalize(Vec3{(p.x - cx) / fx, (p.y - cy) / fy, 1});
            }};
  }
};

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Per-corner errors after the best grid symmetry (detection order is canonical, truth is
// in board order).
std::vector<double> corner_errors(const Corners& found, const Corners& truth, int cols, int rows) {
  std::vector<double> best;
  double best_median = INFINITY;
  for (int t = 0; t < (cols == rows ? 2 : 1); ++t)
    for (int fr = 0; fr < 2; ++fr)
      for (int fc = 0; fc < 2; ++fc) {
        std::vector<double> e;
        for (int r = 0; r < rows; ++r)
          for (int c = 0; c < cols; ++c) {
            int rr = t ? c : r, cc = t ? r : c;
            if (fr) rr = rows - 1 - rr;
            if (fc) cc = cols - 1 - cc;
            const auto& a = found[r * cols + c];
            const auto& b = truth[rr * cols + cc];
            e.push_back(std::hypot(a[0] - b[0], a[1] - b[1]));
          }
        const double m = median(e);
        if (m < best_median) {
          best_median = m;
          best = e;
        }
      }
  return best;
}

struct Score {
  int found = 0;
  double median_px = NAN;
  double seconds = 0;
};

Score detect_all(const SyntheticBoards& boards, const BoardSpec& spec, const char* label) {
  Score s;
  std::vector<double> errors;
  std::vector<double> per_view;
  for (size_t v = 0; v < boards.images.size(); ++v) {
    const BoardDetection d = detect_board(boards.images[v], spec);
    s.seconds += d.seconds;
    if (!d.found) continue;
    ++s.found;
    const auto e = corner_errors(d.corners, boards.true_corners[v], spec.cols, spec.rows);
    per_view.push_back(median(e));
    errors.insert(errors.end(), e.begin(), e.end());
  }
  s.median_px = median(errors);
  std::printf("[synth] %s: found %d/%zu, median corner error %.4f px (worst view median %.3f), %.3f s/view\n",
              label, s.found, boards.images.size(), s.median_px,
              per_view.empty() ? NAN : *std::max_element(per_view.begin(), per_view.end()),
              s.seconds / boards.images.size());
  return s;
}

TEST(SyntheticBoards, DeterministicAndInsideImage) {
  const Kb kb{360, 360, 639.5, 479.5, 0.02, -0.005, 0, 0};
  SyntheticBoardsOptions o;
  o.views = 3;
  const SyntheticBoards a = synthesize_boards(o, kb.lens());
  const SyntheticBoards b = synthesize_boards(o, kb.lens());
  ASSERT_EQ(a.images.size(), 3u);
  ASSERT_EQ(a.true_corners.size(), 3u);
  ASSERT_EQ(a.poses.size(), 3u);
  EXPECT_EQ(a.images[1].rgb, b.images[1].rgb);
  EXPECT_EQ(a.poses[2], b.poses[2]);
  for (const auto& view : a.true_corners) {
    ASSERT_EQ(view.size(), 54u);
    for (const auto& p : view) {
      EXPECT_GT(p[0], 0);
      EXPECT_GT(p[1], 0);
      EXPECT_LT(p[0], 1279);
      EXPECT_LT(p[1], 959);
    }
  }
  // The pose reproduces the true corners: corner (r=1, c=2) at (60, 30, 0) mm.
  const auto& pose = a.poses[0];
  {
    const double th = std::sqrt(pose[0] * pose[0] + pose[1] * pose[1] + pose[2] * pose[2]);
    const Vec3 k = th > 0 ? Vec3{pose[0] / th, pose[1] / th, pose[2] / th} : Vec3{1, 0, 0};
    const Vec3 p{60, 30, 0};
    const Vec3 rotated = std::cos(th) * p + std::sin(th) * cross(k, p) + (1 - std::cos(th)) * dot(k, p) * k;
    const Vec3 pc = rotated + Vec3{pose[3], pose[4], pose[5]};
    const auto px = kb.project(pc);
    ASSERT_TRUE(px.has_value());
    EXPECT_NEAR(px->x, a.true_corners[0][1 * 9 + 2][0], 1e-6);
    EXPECT_NEAR(px->y, a.true_corners[0][1 * 9 + 2][1], 1e-6);
  }
  SyntheticBoardsOptions other = o;
  other.seed = 2;
  EXPECT_NE(synthesize_boards(other, kb.lens()).poses[0], a.poses[0]);
}

TEST(SyntheticBoards, BadOptionsThrow) {
  const Kb kb{360, 360, 639.5, 479.5, 0, 0, 0, 0};
  SyntheticBoardsOptions o;
  o.views = 0;
  EXPECT_THROW(synthesize_boards(o, kb.lens()), InputError);
  o.views = 1;
  o.board = {2, 6, 30};
  EXPECT_THROW(synthesize_boards(o, kb.lens()), InputError);
}

TEST(SyntheticBoards, DetectedOnFisheye190) {
  const Kb kb{360, 360, 639.5, 479.5, 0.02, -0.005, 0, 0};
  SyntheticBoardsOptions o;  // 20 views, 9x6, noise 0.01, blur 0.7
  const SyntheticBoards boards = synthesize_boards(o, kb.lens());
  const Score s = detect_all(boards, o.board, "KB 190 deg 1280x960");
  EXPECT_GE(s.found, 18);
  EXPECT_LT(s.median_px, 0.1);
}

TEST(SyntheticBoards, DetectedOnPinhole) {
  const Pinhole pin{600, 600, 399.5, 299.5};
  SyntheticBoardsOptions o;
  o.camera = CameraModel{"LENSMODEL_PINHOLE", {600, 600, 399.5, 299.5}, 800, 600};
  o.field_deg = 0;
  const SyntheticBoards boards = synthesize_boards(o, pin.lens());
  const Score s = detect_all(boards, o.board, "pinhole 800x600");
  EXPECT_GE(s.found, 18);
  EXPECT_LT(s.median_px, 0.1);
}

// Through calib/camera_model (the default options' KB camera): same pictures as the local KB.
TEST(SyntheticBoards, CameraModelPathMatchesLocalLens) {
  const Kb kb{360, 360, 639.5, 479.5, 0.02, -0.005, 0, 0};
  SyntheticBoardsOptions o;
  o.views = 2;
  const SyntheticBoards a = synthesize_boards(o);
  const SyntheticBoards b = synthesize_boards(o, kb.lens());
  ASSERT_EQ(a.poses.size(), 2u);
  for (int v = 0; v < 2; ++v) {
    for (int i = 0; i < 6; ++i) EXPECT_NEAR(a.poses[v][i], b.poses[v][i], 1e-6);
    for (size_t k = 0; k < a.true_corners[v].size(); ++k) {
      EXPECT_NEAR(a.true_corners[v][k][0], b.true_corners[v][k][0], 1e-6);
      EXPECT_NEAR(a.true_corners[v][k][1], b.true_corners[v][k][1], 1e-6);
    }
  }
  const Score s = detect_all(a, o.board, "KB via camera_model");
  EXPECT_EQ(s.found, 2);
}

// What `synth boards` leaves on disk reads back as the boards it was made from.
TEST(SyntheticBoards, WrittenFilesReadBackAsTheTruth) {
  namespace fs = std::filesystem;
  SyntheticBoardsOptions o;
  o.views = 2;
  const SyntheticBoards boards = synthesize_boards(o);
  const fs::path dir = fs::temp_directory_path() / ("lp_synthetic_boards_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  write_synthetic_boards((dir / "out").string(), o, boards);
  const nlohmann::json truth = read_json_file((dir / "out" / "truth.json").string());
  EXPECT_EQ(truth["board"], nlohmann::json({9, 6}));
  EXPECT_EQ(truth["square_mm"], 30);
  EXPECT_EQ(truth["lensmodel"], o.camera.lensmodel);
  ASSERT_EQ(truth["views"].size(), 2u);
  for (size_t v = 0; v < 2; ++v) {
    const nlohmann::json& view = truth["views"][v];
    EXPECT_EQ(view["file"], v == 0 ? "board_00.png" : "board_01.png");
    ASSERT_EQ(view["corners"].size(), 54u);
    EXPECT_DOUBLE_EQ(view["corners"][17][0].get<double>(), boards.true_corners[v][17][0]);
    EXPECT_DOUBLE_EQ(view["pose"][5].get<double>(), boards.poses[v][5]);
    // 8-bit codes: each value within half a code of what was rendered.
    const CameraImage png = read_camera_image((dir / "out" / view["file"].get<std::string>()).string());
    ASSERT_EQ(png.rgb.size(), boards.images[v].rgb.size());
    double worst = 0;
    for (size_t i = 0; i < png.rgb.size(); ++i)
      worst = std::max(worst, std::abs(double(png.rgb[i]) - std::clamp(double(boards.images[v].rgb[i]), 0.0, 1.0)));
    EXPECT_LE(worst, 0.5 / 255 + 1e-6);
  }
  const CameraModel camera = read_camera_model((dir / "out" / "true_camera.yaml").string());
  EXPECT_EQ(camera.width, 1280);
  ASSERT_EQ(camera.intrinsics.size(), o.camera.intrinsics.size());
  for (size_t i = 0; i < camera.intrinsics.size(); ++i) EXPECT_NEAR(camera.intrinsics[i], o.camera.intrinsics[i], 1e-9);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace lp
