#include "calib/board_detect.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "core/image_io.h"
#include "core/lazy_libs.h"  // mrgingham: in the plugin, as it links OpenCV's codecs

namespace lp {
namespace {

using Corners = std::vector<std::array<double, 2>>;

// The grey image the finders and cornerSubPix work on, 8 bits. An image that fills less than
// half of its range (its 99.9th percentile of luminance under 0.5) is stretched so that the
// percentile lands at full scale first: a 12-bit camera's frames saved in 16 bits (Mono12 in
// a 16-bit PNG) held only 16 grey levels here, and the stereo set so stored came out at
// 0.186 px of cross-validation against 0.119 from its 8-bit JPEGs. Images that use their
// range, every shared set among them, are converted as they were.
cv::Mat to_gray8(const CameraImage& image) {
  const size_t n = size_t(image.width) * image.height;
  std::vector<float> luma(n);
  constexpr int kBins = 4096;
  std::vector<size_t> histogram(kBins + 1, 0);
  for (size_t i = 0; i < n; ++i) {
    const float* p = &image.rgb[3 * i];
    luma[i] = float(0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2]);
    ++histogram[size_t(std::clamp(double(luma[i]), 0.0, 1.0) * kBins)];
  }
  size_t below = 0, bin = 0;
  while (bin < kBins && (below += histogram[bin]) < n - n / 1000) ++bin;
  const double p999 = double(bin + 1) / kBins;
  const double gain = p999 < 0.5 ? 1.0 / p999 : 1.0;
  cv::Mat gray(image.height, image.width, CV_8U);
  for (int y = 0; y < image.height; ++y) {
    auto* row = gray.ptr<uint8_t>(y);
    const float* v = &luma[size_t(y) * image.width];
    for (int x = 0; x < image.width; ++x)
      row[x] = static_cast<uint8_t>(std::clamp(std::lround(double(v[x]) * gain * 255.0), 0L, 255L));
  }
  return gray;
}

// Shortest distance from corner (r, c) to a grid neighbour: the local square size in pixels.
double local_square_px(const std::vector<cv::Point2f>& pts, int cols, int rows, int r, int c) {
  double best = 1e30;
  const cv::Point2f p = pts[r * cols + c];
  const int dr[4] = {-1, 1, 0, 0}, dc[4] = {0, 0, -1, 1};
  for (int k = 0; k < 4; ++k) {
    const int rr = r + dr[k], cc = c + dc[k];
    if (rr < 0 || rr >= rows || cc < 0 || cc >= cols) continue;
    const cv::Point2f d = pts[rr * cols + cc] - p;
    best = std::min(best, std::hypot(double(d.x), double(d.y)));
  }
  return best;
}

struct RefineStats {
  int reverted = 0;
  double median_shift = 0;
};

// cornerSubPix per corner with a half-window of ~0.4 of the local square size, so small or
// strongly curved squares are not blurred together with their neighbours: at least 2 px, at
// most 10 px per 1280 px of the image's long side (at least 10). A fixed 10 px cap made the
// window 4x narrower, relative to the optics' blur, on an image with 4x the pixels: a
// fisheye1 view enlarged 4x was refined 0.2-0.26 px (of the original) away from its own
// corners, which a 10 px half-window at 1032 px puts within 0.05 px of cornerSubPix's with 7.
// A move larger than max_shift (when > 0) is undone.
RefineStats refine(const cv::Mat& gray, std::vector<cv::Point2f>& pts, int cols, int rows,
                   double max_shift) {
  const int max_half = std::max(10, int(10.0 * std::max(gray.cols, gray.rows) / 1280));
  RefineStats stats;
  std::vector<double> shifts;
  const cv::TermCriteria criteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 40, 0.001);
  std::vector<cv::Point2f> one(1);
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      const double square = local_square_px(pts, cols, rows, r, c);
      const int half = std::clamp(static_cast<int>(std::floor(0.4 * square)), 2, max_half);
      one[0] = pts[r * cols + c];
      cv::cornerSubPix(gray, one, cv::Size(half, half), cv::Size(-1, -1), criteria);
      const cv::Point2f d = one[0] - pts[r * cols + c];
      const double shift = std::hypot(double(d.x), double(d.y));
      if (!std::isfinite(shift) || (max_shift > 0 && shift > max_shift)) {
        ++stats.reverted;
        continue;
      }
      shifts.push_back(shift);
      pts[r * cols + c] = one[0];
    }
  }
  if (!shifts.empty()) {
    std::nth_element(shifts.begin(), shifts.begin() + shifts.size() / 2, shifts.end());
    stats.median_shift = shifts[shifts.size() / 2];
  }
  return stats;
}

bool try_classic(const cv::Mat& gray, const BoardSpec& board, std::vector<cv::Point2f>& pts, int flags) {
  return cv::findChessboardCorners(gray, cv::Size(board.cols, board.rows), pts, flags);
}

bool try_sb(const cv::Mat& gray, const BoardSpec& board, std::vector<cv::Point2f>& pts,
            int flags = cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY) {
  return cv::findChessboardCornersSB(gray, cv::Size(board.cols, board.rows), pts, flags);
}

// Scale (<= 1) for the fast SB attempt: long side ~long_side_px, but never so small that a
// square of a board spanning half the image's short side (its longer grid dimension) falls
// below min_square_px; at most 1.
double sb_scale(int width, int height, const BoardSpec& board, const DetectOptions& options) {
  if (options.sb_long_side_px <= 0) return 1.0;
  const double long_side = std::max(width, height), short_side = std::min(width, height);
  double scale = options.sb_long_side_px / long_side;
  const double square_full = 0.5 * short_side / (std::max(board.cols, board.rows) + 1);
  scale = std::max(scale, options.sb_min_square_px / square_full);
  return std::min(1.0, scale);
}

}  // namespace

std::vector<double> intermediate_scales(double first_scale) {
  std::vector<double> scales;
  for (double s = 2 * first_scale; s <= 0.5; s *= 2) scales.push_back(s);
  return scales;
}

namespace {

// mrgingham on a CLAHE-equalised copy (its library call does no equalisation; its CLI does,
// clip limit 8). Returns the corners row-major (gridn per row) and the pyramid level used
// (each level halves the image, so SB-like accuracy is not expected before refinement).
bool try_mrgingham(const cv::Mat& gray, const BoardSpec& board, int pyramid_level,
                   std::vector<cv::Point2f>& pts, int& level_used) {
  cv::Mat equalised;
  auto clahe = cv::createCLAHE();
  clahe->setClipLimit(8);
  clahe->apply(gray, equalised);
  std::vector<cv::Point2d> found;
  level_used = lazy::find_chessboard_mrgingham(found, board.cols, equalised, pyramid_level);
  if (level_used < 0 || found.size() != static_cast<size_t>(board.cols) * board.rows) return false;
  pts.clear();
  for (const auto& p : found) pts.emplace_back(float(p.x), float(p.y));
  return true;
}

// How far the grid zig-zags: along a row or column, two consecutive second differences of
// the corners (the bend at each corner) that point against each other, the smaller of them
// over the local spacing. A lens bends a row one way, however strongly (a catadioptric
// mirror's rim compresses the squares fast, but every bend has the same sense); corner noise
// bends by a pixel at most. A row the detector made up along the board's edge and the shirt
// below it (--board 9x7 for a 9x6 board: x at 247, 282, 308, 344, 368) bends back and forth
// by 9-12 px on a 30 px spacing, and such views made a wrong model with exit 0 (0.85 px off).
// The made-up rows of the stereo set at --board 9x7: 0.40-0.78; real boards of the shared
// sets: 0, and up to 0.28 on KaidanOmni's mirror, whose rim bends rows back near its edge.
constexpr double kMaxZigzag = 0.35;

double grid_zigzag(const std::vector<cv::Point2f>& pts, int cols, int rows) {
  double worst = 0;
  auto line = [&](int n, auto at) {
    for (int i = 0; i + 3 < n; ++i) {
      const cv::Point2f a = at(i), b = at(i + 1), c = at(i + 2), d = at(i + 3);
      const cv::Point2f bend1 = c - 2 * b + a, bend2 = d - 2 * c + b;
      const double m1 = cv::norm(bend1), m2 = cv::norm(bend2), spacing = (cv::norm(c - b) + cv::norm(d - c)) / 2;
      if (!(spacing > 0) || std::min(m1, m2) < 2 || bend1.dot(bend2) >= 0) continue;  // noise, or one sense
      worst = std::max(worst, -bend1.dot(bend2) / (m1 * m2) * std::min(m1, m2) / spacing);
    }
  };
  for (int r = 0; r < rows; ++r) line(cols, [&](int c) { return pts[size_t(r) * size_t(cols) + size_t(c)]; });
  for (int c = 0; c < cols; ++c) line(rows, [&](int r) { return pts[size_t(r) * size_t(cols) + size_t(c)]; });
  return worst;
}

bool valid_points(const std::vector<cv::Point2f>& pts, const BoardSpec& board) {
  if (pts.size() != static_cast<size_t>(board.cols) * board.rows) return false;
  for (const auto& p : pts)
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return false;
  return grid_zigzag(pts, board.cols, board.rows) < kMaxZigzag;
}

// The bright image circle of a fisheye inside a dark surround: centre and radius, or false
// when the image has no such surround (the largest bright blob fills nearly the image) or
// the circle is small.
bool find_image_circle(const cv::Mat& gray, cv::Point2d& centre, double& radius) {
  cv::Mat blurred, mask;
  cv::GaussianBlur(gray, blurred, cv::Size(), 3);
  cv::threshold(blurred, mask, 25, 255, cv::THRESH_BINARY);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  if (contours.empty()) return false;
  const auto& c = *std::max_element(contours.begin(), contours.end(), [](const auto& a, const auto& b) {
    return cv::contourArea(a) < cv::contourArea(b);
  });
  const double area = cv::contourArea(c), image_area = double(gray.cols) * gray.rows;
  if (area > 0.92 * image_area || area < 0.2 * image_area) return false;
  cv::Point2f cf;
  float r = 0;
  cv::minEnclosingCircle(c, cf, r);
  centre = {cf.x, cf.y};
  radius = r;
  return radius > 0.25 * std::min(gray.cols, gray.rows);
}

// Perspective view (size x size, field fov_deg, along the optical axis) of an equidistant
// fisheye with the circle at half_field_deg: the source pixel of view pixel (u, v).
struct RectifiedView {
  cv::Point2d centre;
  double f_fisheye = 1, f_view = 1;
  int size = 0;
  cv::Point2d source(double u, double v) const {
    const double x = u - (size - 1) / 2.0, y = v - (size - 1) / 2.0;
    const double rho = std::hypot(x, y);
    if (rho < 1e-12) return centre;
    const double r = f_fisheye * std::atan2(rho, f_view);
    return {centre.x + r * x / rho, centre.y + r * y / rho};
  }
};

RectifiedView make_view(const cv::Point2d& centre, double radius, double half_field_deg, double fov_deg, int size) {
  RectifiedView v;
  v.centre = centre;
  v.f_fisheye = radius / (half_field_deg * M_PI / 180);
  v.f_view = (size / 2.0) / std::tan(fov_deg * M_PI / 360);
  v.size = size;
  return v;
}

}  // namespace

void canonicalize_corner_order(Corners& corners, int cols, int rows) {
  if (corners.size() != static_cast<size_t>(cols) * rows || corners.empty()) return;
  // Source (row, col) for output (r, c) under each symmetry of the grid's shape.
  struct Map {
    bool transpose, flip_r, flip_c;
  };
  std::vector<Map> maps;
  for (int t = 0; t < (cols == rows ? 2 : 1); ++t)
    for (int fr = 0; fr < 2; ++fr)
      for (int fc = 0; fc < 2; ++fc) maps.push_back({t == 1, fr == 1, fc == 1});
  auto source = [&](const Map& m, int r, int c) {
    int rr = m.transpose ? c : r, cc = m.transpose ? r : c;
    if (m.flip_r) rr = rows - 1 - rr;
    if (m.flip_c) cc = cols - 1 - cc;
    return corners[rr * cols + cc];
  };
  int best = 0;
  double best_d2 = 0, best_x = 0;
  for (size_t i = 0; i < maps.size(); ++i) {
    const auto p0 = source(maps[i], 0, 0), p1 = source(maps[i], 0, cols - 1);
    const double d2 = p0[0] * p0[0] + p0[1] * p0[1];
    const double dx = p1[0] - p0[0], dy = p1[1] - p0[1];
    const double along_x = dx / std::max(1e-12, std::hypot(dx, dy));
    if (i == 0 || d2 < best_d2 || (d2 == best_d2 && along_x > best_x)) {
      best = static_cast<int>(i);
      best_d2 = d2;
      best_x = along_x;
    }
  }
  Corners out(corners.size());
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) out[r * cols + c] = source(maps[best], r, c);
  corners = std::move(out);
}

namespace {

enum class Kind { classic, sb, sb_rectified, mrgingham };
struct Stage {
  Kind kind;
  double scale;  // of the copy it runs on (SB, classic; 1: full resolution)
  int flags;     // of the OpenCV finder (SB, SB on rectified views, classic)
};

std::string label(const Stage& st) {
  return st.kind == Kind::classic     ? "classic"
         : st.kind == Kind::mrgingham ? "mrgingham"
         : st.kind == Kind::sb        ? "sb"
                                      : "sb-rectified";
}

// Cheapest first, measured per stage (thread CPU time, one OpenCV thread) on the seven
// real sets and on rendered 190 deg views (docs/calibration.md, "Board detection"):
// - classic with a global threshold on the downscaled copy: 4-14 ms mean, 35 ms worst,
//   finds every view of the pinhole set and half to two thirds of the fisheye ones, and
//   its corners are the precise ones; with ADAPTIVE_THRESH it finds a few more but costs
//   up to 180 ms when it fails (its FAST_CHECK passes on curved boards), so that variant
//   runs last, at full resolution;
// - SB (EXHAUSTIVE, no ACCURACY) on the downscaled copy: 30-60 ms when it finds the
//   board, 100-230 ms when not; the recall of the cascade;
// - the rectified views only on images with a fisheye circle; full-resolution SB and
//   mrgingham for small or far boards.
// - between the first copy and full resolution, every octave above it up to 1/2
//   (intermediate_scales): OpenCV's finders are not scale-invariant (the classic one's
//   adaptive threshold and dilations, SB's kernel, are sized in pixels), so a board found at
//   1032 px across was lost at 4128 (the same fisheye1 view upscaled 4x), where the cascade
//   went from 640 px straight to full resolution, 20 s of failing attempts per view.
std::vector<Stage> detection_stages(const DetectOptions& options, const BoardSpec& board, double scale,
                                    bool fisheye_circle) {
  const int exhaustive = cv::CALIB_CB_EXHAUSTIVE;
  const int classic_global = cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK;
  const int classic_adaptive = classic_global | cv::CALIB_CB_ADAPTIVE_THRESH;
  const std::vector<double> between = intermediate_scales(scale);
  std::vector<Stage> stages;
  if (options.classic) stages.push_back({Kind::classic, scale, classic_global});
  if (options.sb) stages.push_back({Kind::sb, scale, exhaustive});
  if (options.classic && scale < 1) stages.push_back({Kind::classic, scale, classic_adaptive});
  if (options.classic)
    for (double s : between) stages.push_back({Kind::classic, s, classic_adaptive});
  // Without a fisheye circle, full-resolution classic (8-30 ms on the real sets) before
  // full-resolution SB (70-240 ms when it fails).
  const bool classic_full_early = options.classic && !fisheye_circle && scale < 1;
  if (classic_full_early) stages.push_back({Kind::classic, 1, classic_adaptive});
  if (fisheye_circle) stages.push_back({Kind::sb_rectified, 1, exhaustive});
  if (options.sb)
    for (double s : between) stages.push_back({Kind::sb, s, exhaustive});
  if (options.sb && scale < 1) stages.push_back({Kind::sb, 1, exhaustive});
  // mrgingham finds only N x N grids and equalises by itself: one attempt, on the plain image.
  if (options.mrgingham && board.cols == board.rows) stages.push_back({Kind::mrgingham, 1, 0});
  if (options.classic && !classic_full_early) stages.push_back({Kind::classic, 1, classic_adaptive});
  // OpenCV's most thorough call as the recall floor: it found nothing the stages above
  // missed on our sets, but its internal upsampling can resolve small boards; it costs
  // 150-400 ms and only views that everything else missed pay for it.
  if (options.sb) stages.push_back({Kind::sb, 1, exhaustive | cv::CALIB_CB_ACCURACY});
  return stages;
}

// One image's cascade of attempts: the corners of the first that succeeds, and the list of
// what was tried with its times.
class Cascade {
 public:
  Cascade(const cv::Mat& gray, const BoardSpec& board, const DetectOptions& options, BoardDetection& result)
      : gray_(gray), board_(board), options_(options), result_(result) {
    // SB and the early classic attempt run on a copy downscaled by `scale`; corners are
    // mapped back to full resolution and refined there, the move limit scaled by 1 / scale
    // (the detector's error grows with the downscaling).
    scale_ = sb_scale(gray.cols, gray.rows, board, options);
    const bool fisheye_circle =
        options.rectified && options.sb && find_image_circle(gray, circle_centre_, circle_radius_);
    stages_ = detection_stages(options, board, scale_, fisheye_circle);
  }

  bool run(const cv::Mat& img, const std::string& suffix) {
    for (const Stage& st : stages_) {
      // mrgingham equalises by itself; the ACCURACY call is the plain image's last resort.
      if (!suffix.empty() && (st.kind == Kind::mrgingham || (st.flags & cv::CALIB_CB_ACCURACY))) continue;
      if (skip_classic_ && st.kind == Kind::classic) continue;
      const auto t0 = std::chrono::steady_clock::now();
      const bool ok = attempt(img, st, label(st) + suffix);
      char ms[32];
      std::snprintf(ms, sizeof ms, " %.0f ms",
                    1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      tried_ += ms;
      if (ok) return true;
      // After the cheap stages, one look for a board of another size: when the image shows
      // one larger than --board, the slow stages would search it for minutes (67 s per view
      // of a 9x6 board with --board 7x5) and find nothing.
      if (suffix.empty() && st.kind == Kind::sb && st.scale == scale_ && !(st.flags & cv::CALIB_CB_ACCURACY)) {
        const Seen seen = other_board_size(img);
        if (seen == Seen::larger) return false;
        // A whole board smaller than --board: OpenCV's classic finder, told to look for a
        // larger grid among that board's quads, searches their combinations for minutes (an
        // 8x5 board at 1920x1080 with --board 9x6: 14 s downscaled, 228 s at full resolution,
        // per view). SB's stages stay (bounded: 0.6 and 2.9 s there); the classic ones go.
        if (seen == Seen::smaller_whole) skip_classic_ = true;
      }
    }
    return false;
  }
  // The size of a board seen that --board cannot be part of; cols 0 when none.
  const std::array<int, 2>& other_size() const { return other_; }
  // The size of a whole board seen (inside the image, not cut by its edge) smaller than
  // --board; cols 0 when none.
  const std::array<int, 2>& smaller_size() const { return smaller_; }
  const std::vector<cv::Point2f>& points() const { return pts_; }
  const std::string& tried() const { return tried_; }

 private:
  // SB or classic, maybe on the downscaled copy: corners mapped back to full resolution;
  // the refinement's move limit in `limit`.
  bool find_scaled(const cv::Mat& img, const Stage& st, double& limit) {
    cv::Mat small = img;
    if (st.scale < 1) cv::resize(img, small, cv::Size(), st.scale, st.scale, cv::INTER_AREA);
    const double sx = double(small.cols) / img.cols, sy = double(small.rows) / img.rows;
    if (sx < 1) {
      char at[32];
      std::snprintf(at, sizeof at, "@%.2f", std::min(sx, sy));
      tried_ += at;
    }
    if (st.kind == Kind::sb && (st.flags & cv::CALIB_CB_ACCURACY)) tried_ += " accuracy";
    if (st.kind == Kind::classic && (st.flags & cv::CALIB_CB_ADAPTIVE_THRESH)) tried_ += " adaptive";
    // SB without CALIB_CB_ACCURACY: that costs ~4x the time (an internal upsampled pass),
    // cornerSubPix at full resolution gives the precision, and on the real sets it found
    // fewer views (Ladybug 2 and 3 only without it).
    const bool ok =
        st.kind == Kind::classic ? try_classic(small, board_, pts_, st.flags) : try_sb(small, board_, pts_, st.flags);
    for (auto& p : pts_) {  // pixel centres at integers: x_full + 0.5 = (x_small + 0.5) / s
      p.x = static_cast<float>((p.x + 0.5) / sx - 0.5);
      p.y = static_cast<float>((p.y + 0.5) / sy - 0.5);
    }
    // classic's own corners are refined without a move limit (its quads are coarse).
    limit = st.kind == Kind::classic ? 0 : limit / std::min(sx, sy);
    return ok;
  }

  // SB on local perspective views of the fisheye circle, corners mapped back; the move
  // limit grows with the view's local magnification (a view pixel spans up to a few fisheye
  // pixels near its centre).
  bool find_rectified(const cv::Mat& img, const Stage& st, double& limit) {
    for (double fov : options_.rectified_fov_deg) {
      const RectifiedView view =
          make_view(circle_centre_, circle_radius_, options_.rectified_half_field_deg, fov, options_.rectified_size_px);
      cv::Mat mx(view.size, view.size, CV_32F), my(view.size, view.size, CV_32F);
      for (int v = 0; v < view.size; ++v)
        for (int u = 0; u < view.size; ++u) {
          const cv::Point2d q = view.source(u, v);
          mx.at<float>(v, u) = float(q.x);
          my.at<float>(v, u) = float(q.y);
        }
      cv::Mat rect;
      cv::remap(img, rect, mx, my, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
      pts_.clear();
      if (!try_sb(rect, board_, pts_, st.flags) || !valid_points(pts_, board_)) continue;
      double magnification = 1;
      for (auto& p : pts_) {
        const cv::Point2d q = view.source(p.x, p.y), q1 = view.source(p.x + 1, p.y);
        magnification = std::max(magnification, std::hypot(q1.x - q.x, q1.y - q.y));
        p = cv::Point2f(float(q.x), float(q.y));
      }
      if (limit > 0) limit *= magnification;
      return true;
    }
    return false;
  }

  bool attempt(const cv::Mat& img, const Stage& st, const std::string& name) {
    if (!tried_.empty()) tried_ += ", ";
    tried_ += name;
    pts_.clear();
    bool ok = false;
    double limit = options_.max_refine_shift_px;
    if (st.kind == Kind::classic || st.kind == Kind::sb) {
      ok = find_scaled(img, st, limit);
    } else if (st.kind == Kind::mrgingham) {
      int level = 0;
      ok = try_mrgingham(img, board_, options_.mrgingham_pyramid_level, pts_, level);
      if (limit > 0) limit *= double(1 << std::clamp(level, 0, 8));
    } else {
      ok = find_rectified(img, st, limit);
    }
    if (!ok || !valid_points(pts_, board_)) return false;
    // Refine on the original grey image: CLAHE changes edge profiles.
    if (st.kind == Kind::classic || options_.refine_sb) {
      const RefineStats stats = refine(gray_, pts_, board_.cols, board_.rows, limit);
      result_.refine_reverted = stats.reverted;
      result_.refine_median_shift_px = stats.median_shift;
    }
    result_.method = name;
    return true;
  }

  // SB on the downscaled copy with CALIB_CB_LARGER from the smallest pattern: it grows the
  // grid to the whole board it sees, whose size comes back in the meta matrix. A board
  // larger than --board in some direction (in either orientation) is `larger`; a smaller
  // one is `smaller_whole` only when every corner lies more than a square's width inside the
  // image (else it may be part of the right board, cut by the image edge).
  enum class Seen { none, larger, smaller_whole };
  Seen other_board_size(const cv::Mat& img) {
    const auto t0 = std::chrono::steady_clock::now();
    cv::Mat small = img;
    if (scale_ < 1) cv::resize(img, small, cv::Size(), scale_, scale_, cv::INTER_AREA);
    std::vector<cv::Point2f> pts;
    cv::Mat meta;
    const bool found = cv::findChessboardCornersSB(small, cv::Size(3, 3), pts,
                                                           cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_LARGER, meta);
    char ms[48];
    std::snprintf(ms, sizeof ms, ", size check %.0f ms",
                  1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    tried_ += ms;
    if (!found || meta.empty()) return Seen::none;
    const int cols = meta.cols, rows = meta.rows;
    // A grid grown into the background (rows made up along the board's edge) is no board.
    if (pts.size() != size_t(cols) * size_t(rows) || grid_zigzag(pts, cols, rows) >= kMaxZigzag) return Seen::none;
    // Said the way --board is written: the longer side first when --board's is.
    const std::array<int, 2> size =
        (cols >= rows) == (board_.cols >= board_.rows) ? std::array<int, 2>{cols, rows} : std::array<int, 2>{rows, cols};
    const bool fits = (cols <= board_.cols && rows <= board_.rows) || (cols <= board_.rows && rows <= board_.cols);
    if (!fits) {
      other_ = size;
      return Seen::larger;
    }
    if (cols * rows >= board_.cols * board_.rows) return Seen::none;  // --board itself
    double margin = std::numeric_limits<double>::infinity(), square = 0;
    for (int r = 0; r < rows; ++r)
      for (int c = 0; c < cols; ++c) {
        const cv::Point2f& p = pts[size_t(r) * cols + c];
        margin = std::min({margin, double(p.x), double(p.y), double(small.cols - 1 - p.x), double(small.rows - 1 - p.y)});
        square = std::max(square, local_square_px(pts, cols, rows, r, c));
      }
    if (!(margin > square)) return Seen::none;
    smaller_ = size;
    return Seen::smaller_whole;
  }

  const cv::Mat& gray_;
  const BoardSpec& board_;
  const DetectOptions& options_;
  BoardDetection& result_;
  double scale_ = 1;
  cv::Point2d circle_centre_;
  double circle_radius_ = 0;
  std::vector<Stage> stages_;
  std::vector<cv::Point2f> pts_;
  std::string tried_;
  std::array<int, 2> other_{0, 0}, smaller_{0, 0};
  bool skip_classic_ = false;
};

}  // namespace

BoardDetection detect_board(const CameraImage& image, const BoardSpec& board, const DetectOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (image.width <= 0 || image.height <= 0 ||
      image.rgb.size() != static_cast<size_t>(image.width) * image.height * 3)
    throw InputError("detect_board: empty or inconsistent image");
  if (board.cols < 3 || board.rows < 3)
    throw InputError("detect_board: board needs at least 3x3 inner corners, got " +
                     std::to_string(board.cols) + "x" + std::to_string(board.rows));

  BoardDetection result;
  const cv::Mat gray = to_gray8(image);
  Cascade cascade(gray, board, options, result);
  bool found = cascade.run(gray, "");
  const bool other_board = cascade.other_size()[0] > 0;
  const bool smaller_board = cascade.smaller_size()[0] > 0;
  // A whole board seen has the contrast the equalised pass would give.
  if (!found && !other_board && !smaller_board && options.clahe &&
      (options.classic || options.sb)) {  // mrgingham equalised already
    cv::Mat equalised;
    cv::createCLAHE(2.0, cv::Size(8, 8))->apply(gray, equalised);
    found = cascade.run(equalised, "+clahe");
  }
  const std::string& tried = cascade.tried();
  if (found) {
    result.found = true;
    result.corners.reserve(cascade.points().size());
    for (const auto& p : cascade.points()) result.corners.push_back({double(p.x), double(p.y)});
    canonicalize_corner_order(result.corners, board.cols, board.rows);
  } else if (other_board || smaller_board) {
    const std::array<int, 2>& size = other_board ? cascade.other_size() : cascade.smaller_size();
    result.other_cols = size[0];
    result.other_rows = size[1];
    result.reason = "found " + std::to_string(result.other_cols) + "x" + std::to_string(result.other_rows) +
                    " inner corners, --board says " + std::to_string(board.cols) + "x" + std::to_string(board.rows) +
                    " (tried " + tried + ")";
  } else {
    result.method.clear();
    result.reason = "no " + std::to_string(board.cols) + "x" + std::to_string(board.rows) +
                    " inner-corner chessboard found (tried " + (tried.empty() ? "nothing" : tried) + ")";
  }
  result.attempts = tried;
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

BoardDetections detect_boards(const std::vector<std::string>& images, const BoardSpec& board,
                              const DetectOptions& options, const std::function<void()>& on_image) {
  const auto t0 = std::chrono::steady_clock::now();
  const size_t n = images.size();
  BoardDetections out;
  out.images = images;
  out.per_image.resize(n);
  out.corners.resize(n);
  std::vector<std::array<int, 2>> sizes(n);
  std::vector<int> orientation(n, 1);
  std::vector<std::string> errors(n);
  tbb::parallel_for(size_t(0), n, [&](size_t i) {
    try {
      const CameraImage img = read_camera_image(images[i]);
      sizes[i] = {img.width, img.height};
      orientation[i] = img.orientation;
      out.per_image[i] = detect_board(img, board, options);
    } catch (const InputError& e) {
      errors[i] = e.what();
    }
    if (on_image) on_image();
  });
  // Turned shots into the frame of the others (an image that could not be read has size 0:
  // unknown): such a set had been refused ("one set needs one orientation"), and one with
  // some shots upside down (Orientation 3) calibrated with its principal point mixed from two
  // frames.
  turn_views_into_one_frame(out, sizes, orientation, board);
  for (size_t i = 0; i < n; ++i) {  // the first error in the given order
    if (!errors[i].empty()) throw InputError(errors[i]);
    if (i == 0) {
      out.width = sizes[i][0];
      out.height = sizes[i][1];
    } else if (sizes[i][0] != out.width || sizes[i][1] != out.height) {
      throw InputError(images[i] + ": " + std::to_string(sizes[i][0]) + "x" + std::to_string(sizes[i][1]) +
                       " differs from the first image's " + std::to_string(out.width) + "x" +
                       std::to_string(out.height) + " (one camera, one resolution)" +
                       turned_size_hint(sizes[i][0], sizes[i][1], out.width, out.height));
    }
    out.turned += orientation[i] != 1;
    if (out.per_image[i].found) {
      out.corners[i] = out.per_image[i].corners;
      ++out.found;
    }
  }
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

void turn_views_into_one_frame(BoardDetections& d, std::vector<std::array<int, 2>>& shown,
                               const std::vector<int>& orientation, const BoardSpec& board) {
  d.image_orientation = orientation;
  std::vector<size_t> known;
  for (size_t i = 0; i < shown.size(); ++i)
    if (shown[i][0] > 0) known.push_back(i);
  if (known.empty()) return;
  const auto stored = [&](size_t i) {
    return orientation[i] >= 5 ? std::array<int, 2>{shown[i][1], shown[i][0]} : shown[i];
  };
  for (size_t i : known)
    if (stored(i) != stored(known[0])) return;  // not one sensor: the size checks name the odd one
  std::map<int, int> seen;
  for (size_t i : known) ++seen[orientation[i]];
  int ref = orientation[known[0]];
  for (const auto& [o, count] : seen)
    if (count > seen[ref]) ref = o;
  d.orientation = ref;
  if (seen.size() == 1) return;
  size_t ref_image = known[0];
  while (orientation[ref_image] != ref) ++ref_image;
  const auto [sw, sh] = stored(known[0]);
  for (size_t i : known) {
    if (orientation[i] == ref) continue;
    auto& corners = d.per_image[i].corners;
    for (auto& c : corners) c = shown_from_stored(ref, sw, sh, stored_from_shown(orientation[i], sw, sh, c));
    // Labelled as the detector labels a board in this frame (canonical in the turned image
    // is not here): the same model as from the views shot unturned.
    if (!corners.empty()) canonicalize_corner_order(corners, board.cols, board.rows);
    if (i < d.corners.size() && !d.corners[i].empty()) d.corners[i] = corners;
    shown[i] = shown[ref_image];
    ++d.reoriented;
  }
}

std::vector<std::array<double, 2>> corners_as_image_shows_them(const BoardDetections& d, size_t i) {
  std::vector<std::array<double, 2>> corners = d.corners[i];
  if (i >= d.image_orientation.size() || d.image_orientation[i] == d.orientation) return corners;
  const bool swap = d.orientation >= 5;
  const int sw = swap ? d.height : d.width, sh = swap ? d.width : d.height;
  for (auto& c : corners)
    c = shown_from_stored(d.image_orientation[i], sw, sh, stored_from_shown(d.orientation, sw, sh, c));
  return corners;
}

}  // namespace lp
