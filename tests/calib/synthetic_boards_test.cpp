#include "calib/synthetic_boards.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "calib/board_detect.h"
#include "core/error.h"

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

}  // namespace
}  // namespace lp
