#include "probe/mirror_ball.h"

#include <fmt/format.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <random>
#include <cstdlib>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "core/error.h"
#include "probe/ball_rim_fit.h"

namespace lp {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

Vec3 reflect(Vec3 v, Vec3 n) { return v - (2 * dot(v, n)) * n; }

}  // namespace

// ---------------------------------------------------------------------------------------
// Projection

MirrorBallProjection::MirrorBallProjection(const BallInImage& ball, const MirrorBallCamera& camera,
                                           int image_width)
    : ball_(ball), camera_(camera) {
  if (!(ball.radius_px > 0) || !std::isfinite(ball.cx) || !std::isfinite(ball.cy))
    throw InputError("mirror ball: radius must be positive and the centre finite");
  if (camera.distance_in_radii && camera.fov_deg)
    throw InputError("mirror ball: give the camera distance or its field of view, not both");
  if (!(camera.reflectivity > 0 && camera.reflectivity <= 1))
    throw InputError("mirror ball: reflectivity must be in (0, 1]");
  if (!is_rotation(camera.world_from_probe, 1e-6))
    throw InputError("mirror ball: world_from_probe is not a rotation");
  probe_from_world_ = transpose(camera.world_from_probe);
  if (camera.distance_in_radii) {
    if (!(*camera.distance_in_radii > 1))
      throw InputError("mirror ball: camera distance must exceed one ball radius");
    distance_ = *camera.distance_in_radii;
  } else if (camera.fov_deg) {
    const double fov = *camera.fov_deg;
    if (!(fov > 0 && fov < 180)) throw InputError("mirror ball: field of view must be in (0, 180) degrees");
    if (image_width <= 0) throw InputError("mirror ball: a field of view needs the image width");
    const double f = 0.5 * image_width / std::tan(0.5 * fov * M_PI / 180);
    distance_ = std::sqrt(1 + (f / ball.radius_px) * (f / ball.radius_px));
  }
  if (distance_) tan_alpha_ = 1 / std::sqrt(*distance_ * *distance_ - 1);
}

double MirrorBallProjection::distance_in_radii() const {
  return distance_ ? *distance_ : std::numeric_limits<double>::infinity();
}

double MirrorBallProjection::max_reflection_angle() const {
  return distance_ ? M_PI - std::asin(1 / *distance_) : M_PI;
}

std::optional<MirrorBallProjection::Hit> MirrorBallProjection::hit(double x, double y) const {
  const double a = (x - ball_.cx) / ball_.radius_px;
  const double b = -(y - ball_.cy) / ball_.radius_px;
  const double rho2 = a * a + b * b;
  if (rho2 > 1) return std::nullopt;
  Vec3 v, n;
  if (!distance_) {
    v = {1, 0, 0};
    n = {-std::sqrt(std::max(0.0, 1 - rho2)), -a, b};
  } else {
    const double d = *distance_;
    v = normalize(Vec3{1, -a * tan_alpha_, b * tan_alpha_});
    const Vec3 c{-d, 0, 0};
    const double cw = dot(c, v);
    const double disc = std::max(0.0, cw * cw - (d * d - 1));
    const double t = -cw - std::sqrt(disc);
    n = normalize(c + t * v);
  }
  const Vec3 r = normalize(reflect(v, n));
  return Hit{camera_.world_from_probe * r, std::clamp(-dot(v, n), 0.0, 1.0)};
}

double MirrorBallProjection::reflection_angle(Vec3 world_direction) const {
  const Vec3 r = normalize(probe_from_world_ * world_direction);
  return angle_between(r, Vec3{-1, 0, 0});
}

std::optional<std::array<double, 2>> MirrorBallProjection::image_point(Vec3 world_direction) const {
  const Vec3 r = normalize(probe_from_world_ * world_direction);
  double a = 0, b = 0;
  if (!distance_) {
    const Vec3 m = r - Vec3{1, 0, 0};
    const double len = length(m);
    if (len < 1e-12) return std::nullopt;
    const Vec3 n = (1 / len) * m;
    a = -n.y;
    b = n.z;
  } else {
    const double d = *distance_;
    const double psi = angle_between(r, Vec3{-1, 0, 0});
    if (psi >= max_reflection_angle()) return std::nullopt;
    const double perp = std::hypot(r.y, r.z);
    const Vec3 u = perp > 1e-15 ? Vec3{0, r.y / perp, r.z / perp} : Vec3{0, 1, 0};
    // 2-D problem in the plane (s = -X, t = u): camera at (d, 0), hit P = (cos g, sin g).
    auto psi_of = [d](double g) {
      const double ps = std::cos(g), pt = std::sin(g);
      double ws = ps - d, wt = pt;
      const double wl = std::hypot(ws, wt);
      ws /= wl;
      wt /= wl;
      const double wp = ws * ps + wt * pt;
      return std::atan2(wt - 2 * wp * pt, ws - 2 * wp * ps);
    };
    double lo = 0, hi = std::acos(1 / d);
    double g = std::clamp(0.5 * psi, lo, hi);
    for (int it = 0; it < 100; ++it) {
      const double f = psi_of(g) - psi;
      if (f > 0) hi = g; else lo = g;
      if (std::abs(f) < 1e-14 || hi - lo < 1e-13) break;
      const double h = 1e-7;
      const double slope = (psi_of(g + h) - psi_of(g - h)) / (2 * h);
      double next = slope > 0 ? g - f / slope : 0.5 * (lo + hi);
      if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
      g = next;
    }
    const Vec3 p = std::cos(g) * Vec3{-1, 0, 0} + std::sin(g) * u;
    const Vec3 w = p + Vec3{d, 0, 0};  // from the camera at (-d, 0, 0) to P
    a = -(w.y / w.x) / tan_alpha_;
    b = (w.z / w.x) / tan_alpha_;
  }
  return std::array<double, 2>{ball_.cx + a * ball_.radius_px, ball_.cy - b * ball_.radius_px};
}

double MirrorBallProjection::reflectivity(double cos_incidence) const {
  const double f0 = camera_.reflectivity;
  if (!camera_.fresnel) return f0;
  const double m = 1 - std::clamp(cos_incidence, 0.0, 1.0);
  return f0 + (1 - f0) * m * m * m * m * m;
}

// ---------------------------------------------------------------------------------------
// Detection

namespace {

struct Circle {
  double cx = 0, cy = 0, r = 0;
};

double cut_fraction(const Circle& c, int w, int h) {
  int out = 0;
  const int n = 720;
  for (int k = 0; k < n; ++k) {
    const double t = 2 * M_PI * (k + 0.5) / n;
    const double x = c.cx + c.r * std::cos(t), y = c.cy + c.r * std::sin(t);
    if (x < 0 || y < 0 || x > w || y > h) ++out;
  }
  return double(out) / n;
}

// ---- Region contrast (coarse-to-fine search and confidence) ----

// One pyramid level of feature images: compressed colour (median-filtered, suppressing
// speckle) and the log of local high-frequency energy (texture), each channel divided by
// its noise scale (the median absolute difference between pixels 2 apart, about the
// median filter's correlation length), so that a contrast of 1 is one typical fluctuation of the
// image's own texture.
struct FeatureLevel {
  cv::Mat feat;  // CV_32FC4
  cv::Mat ok;    // CV_8U, 1 where every source pixel under the level pixel is valid
  double sx = 1, sy = 1;
  double s() const { return std::sqrt(sx * sy); }
};

FeatureLevel make_level(const cv::Mat& col, const cv::Mat& energy, const cv::Mat& valid01, int factor) {
  FeatureLevel L;
  const int lw = std::max(8, int(std::lround(double(col.cols) / factor)));
  const int lh = std::max(8, int(std::lround(double(col.rows) / factor)));
  L.sx = double(col.cols) / lw;
  L.sy = double(col.rows) / lh;
  cv::Mat c, e, v;
  if (factor == 1) {
    c = col.clone(), e = energy.clone(), v = valid01.clone();
  } else {
    cv::resize(col, c, cv::Size(lw, lh), 0, 0, cv::INTER_AREA);
    cv::resize(energy, e, cv::Size(lw, lh), 0, 0, cv::INTER_AREA);
    cv::resize(valid01, v, cv::Size(lw, lh), 0, 0, cv::INTER_AREA);
  }
  cv::medianBlur(c, c, 3);
  cv::Mat le;
  cv::log(e + 1e-3, le);
  std::vector<cv::Mat> ch;
  cv::split(c, ch);
  ch.push_back(le);
  cv::Mat okf = v >= 0.999f;
  cv::erode(okf, L.ok, cv::Mat());  // next to invalid pixels, not at the image border
  // Noise scale per channel.
  const float floors[4] = {0.004f, 0.004f, 0.004f, 0.05f};
  for (int k = 0; k < 4; ++k) {
    std::vector<float> d;
    d.reserve(2 * size_t(lw) * lh);
    for (int y = 0; y < lh; ++y)
      for (int x = 0; x < lw; ++x) {
        if (!L.ok.at<uint8_t>(y, x)) continue;
        const float f = ch[k].at<float>(y, x);
        if (x + 2 < lw && L.ok.at<uint8_t>(y, x + 2)) d.push_back(std::abs(ch[k].at<float>(y, x + 2) - f));
        if (y + 2 < lh && L.ok.at<uint8_t>(y + 2, x)) d.push_back(std::abs(ch[k].at<float>(y + 2, x) - f));
      }
    float noise = floors[k];
    if (!d.empty()) {
      std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
      noise = std::max(noise, d[d.size() / 2]);
    }
    ch[k] /= noise;
  }
  cv::merge(ch, L.feat);
  return L;
}

// Bilinear 4-channel sample at level coordinates (pixel centres at +0.5); false outside
// the level or on a pixel that is not ok.
bool sample4(const FeatureLevel& L, double x, double y, cv::Vec4f* out) {
  const cv::Mat& m = L.feat;
  if (!(x >= 0.5 && y >= 0.5 && x <= m.cols - 0.5 && y <= m.rows - 0.5)) return false;
  if (!L.ok.at<uint8_t>(std::min(m.rows - 1, int(y)), std::min(m.cols - 1, int(x)))) return false;
  const double fx = x - 0.5, fy = y - 0.5;
  const int x0 = std::min(int(fx), m.cols - 2), y0 = std::min(int(fy), m.rows - 2);
  const float ax = float(fx - x0), ay = float(fy - y0);
  const cv::Vec4f* r0 = m.ptr<cv::Vec4f>(y0);
  const cv::Vec4f* r1 = m.ptr<cv::Vec4f>(y0 + 1);
  *out = (1 - ay) * ((1 - ax) * r0[x0] + ax * r0[x0 + 1]) + ay * ((1 - ax) * r1[x0] + ax * r1[x0 + 1]);
  return true;
}

// A circle's contrast: per angle, the feature means over a thin inner annulus (1-3 level
// px inside) and a thin outer one (1-3 px outside); the contrast c is the largest
// normalised channel difference. score = R times the mean over all angles of a soft
// support clamp((c - kSupport / 2) / kSupport, 0, 1) (+ 0.02 log(1 + c) to break ties
// between saturated edges): the length of boundary that separates differing regions, so
// that the ball beats the round highlights it reflects (an angle whose annuli leave the
// image or touch invalid pixels counts 0); support = share of the visible angles with
// c >= kSupport.
constexpr double kSupport = 3.0;
struct RegionScore {
  double score = 0, support = 0, visible = 0;
  // The score with circles less than 97 % seen fading out: seeds for a ball wholly in
  // view, which large circles half outside a textured image outscore otherwise.
  double score_whole = 0;
};

// cos and sin of 2 pi (k + 0.5) / angles, k < angles: region_score's directions, computed
// once per angle count and thread (the search scores hundreds of thousands of circles with
// the same few counts; the sines were an eighth of find_ball's time).
const std::vector<std::array<double, 2>>& ring_directions(int angles) {
  thread_local std::map<int, std::vector<std::array<double, 2>>> cache;  // nodes stay put
  auto& dirs = cache[angles];
  if (dirs.empty())
    for (int k = 0; k < angles; ++k) {
      const double t = 2 * M_PI * (k + 0.5) / angles;
      dirs.push_back({std::cos(t), std::sin(t)});
    }
  return dirs;
}

RegionScore region_score(const FeatureLevel& L, const Circle& c_full, int angles, double max_cut) {
  const double cx = c_full.cx / L.sx, cy = c_full.cy / L.sy, r = c_full.r / L.s();
  RegionScore out;
  if (r < 4) return out;
  int vis = 0, sup = 0;
  double sum = 0;
  const auto& dirs = ring_directions(angles);
  for (int k = 0; k < angles; ++k) {
    const double dx = dirs[size_t(k)][0], dy = dirs[size_t(k)][1];
    cv::Vec4f in(0, 0, 0, 0), outv(0, 0, 0, 0), v;
    int n_in = 0, n_out = 0;
    for (int j = 1; j <= 3; ++j) {
      if (sample4(L, cx + (r - j) * dx, cy + (r - j) * dy, &v)) in += v, ++n_in;
      if (sample4(L, cx + (r + j) * dx, cy + (r + j) * dy, &v)) outv += v, ++n_out;
      if (!n_in || !n_out) break;  // the annuli start at the circle: the first samples must be seen
    }
    if (!n_in || !n_out) continue;
    ++vis;
    const cv::Vec4f d = in * (1.0f / n_in) - outv * (1.0f / n_out);
    const double con = std::max({std::abs(d[0]), std::abs(d[1]), std::abs(d[2]), std::abs(d[3])});
    sum += std::clamp((con - 0.5 * kSupport) / kSupport, 0.0, 1.0) + 0.02 * std::log1p(con);
    if (con >= kSupport) ++sup;
  }
  out.visible = double(vis) / angles;
  // Unseen angles count as the seen ones' mean, so that a ball overflowing the crop is
  // not pushed inside it; circles less than half visible fade out (the cut check
  // after the fit decides whether a ball is too cut).
  const double fade = std::min(1.0, out.visible / 0.5);
  out.score = vis ? c_full.r * sum / vis * fade * fade : 0;
  const double fade_whole = std::min(1.0, out.visible / 0.97);
  out.score_whole = vis ? c_full.r * sum / vis * fade_whole * fade_whole : 0;
  out.support = vis ? double(sup) / vis : 0;
  return out;
}

int angles_for(const FeatureLevel& L, const Circle& c) {
  return std::clamp(int(std::lround(M_PI * c.r / L.s())), 48, 256);
}

// Local search around c (full-res coordinates) on one level: +-2 level px in centre and
// radius, step 0.5 level px.
Circle local_search(const FeatureLevel& L, const Circle& c, double r_min, double r_max, double max_cut,
                    bool whole = false) {
  const double sx = L.sx, sy = L.sy, s = L.s();
  const int n = 9;
  std::vector<double> scores(size_t(n) * n * n, -1);
  const int angles = angles_for(L, c);
  tbb::parallel_for(0, n * n, [&](int ij) {
    const int i = ij / n, j = ij % n;
    for (int k = 0; k < n; ++k) {
      const Circle q{c.cx + (i - 4) * 0.5 * sx, c.cy + (j - 4) * 0.5 * sy, c.r + (k - 4) * 0.5 * s};
      if (q.r < r_min || q.r > r_max) continue;
      const RegionScore rs = region_score(L, q, angles, max_cut);
      scores[size_t(ij) * n + k] = whole ? rs.score_whole : rs.score;
    }
  });
  const size_t best = size_t(std::max_element(scores.begin(), scores.end()) - scores.begin());
  if (scores[best] < 0) return c;
  const int i = int(best / (n * n)), j = int(best / n % n), k = int(best % n);
  // Sub-step: a parabola through the best and its two neighbours along each axis.
  auto at = [&](int a, int b, int d) { return scores[(size_t(a) * n + b) * n + d]; };
  auto vertex = [](double m, double z, double p) {
    const double den = m - 2 * z + p;
    return m >= 0 && p >= 0 && den < 0 ? std::clamp(0.5 * (m - p) / den, -0.5, 0.5) : 0.0;
  };
  const double di = i > 0 && i < n - 1 ? vertex(at(i - 1, j, k), at(i, j, k), at(i + 1, j, k)) : 0;
  const double dj = j > 0 && j < n - 1 ? vertex(at(i, j - 1, k), at(i, j, k), at(i, j + 1, k)) : 0;
  const double dk = k > 0 && k < n - 1 ? vertex(at(i, j, k - 1), at(i, j, k), at(i, j, k + 1)) : 0;
  return {c.cx + (i - 4 + di) * 0.5 * sx, c.cy + (j - 4 + dj) * 0.5 * sy, c.r + (k - 4 + dk) * 0.5 * s};
}

// Exhaustive search on the coarsest level: every centre and radius on the level's pixel
// grid; the best few local maxima (apart by > 3 level px) as seeds, in full-res coordinates:
// `keep` by the score, then `keep_whole` by the score for balls wholly in view, then
// `keep_small` by that score per unit radius (the share of the rim with contrast). The
// score grows with the radius, so in an uncropped photo (a ball a sixth of the frame wide)
// large circles through the texture took every seed of the first two kinds; the third is
// blind to size. All come from one pass (each circle's score is most of find_ball's fixed
// cost).
std::vector<std::pair<Circle, bool>> coarse_seeds(const FeatureLevel& L, double r_min, double r_max, int keep,
                                                  int keep_whole, int keep_small, double max_cut) {
  const int lw = L.feat.cols, lh = L.feat.rows;
  const int r0 = std::max(4, int(std::ceil(r_min / L.s()))), r1 = int(std::floor(r_max / L.s()));
  if (r1 < r0) return {};
  const int nr = r1 - r0 + 1;
  const size_t cells = size_t(lw + 1) * (lh + 1) * nr;
  std::vector<float> sc(cells, 0.f), sc_whole(cells, 0.f), sc_small(cells, 0.f);
  tbb::parallel_for(0, lh + 1, [&](int y) {
    for (int x = 0; x <= lw; ++x)
      for (int r = r0; r <= r1; ++r) {
        const RegionScore rs = region_score(L, {x * L.sx, y * L.sy, r * L.s()}, 48, max_cut);
        const size_t id = (size_t(y) * (lw + 1) + x) * nr + (r - r0);
        sc[id] = float(rs.score), sc_whole[id] = float(rs.score_whole), sc_small[id] = float(rs.score_whole / r);
      }
  });
  std::vector<std::pair<Circle, bool>> out;
  std::vector<std::array<int, 3>> picked;
  for (const int kind : {0, 1, 2}) {
    const bool whole = kind > 0;
    const std::vector<float>& score = kind == 0 ? sc : kind == 1 ? sc_whole : sc_small;
    const int want = kind == 0 ? keep : kind == 1 ? keep_whole : keep_small;
    const size_t first = picked.size();
    std::vector<size_t> order(cells);
    std::iota(order.begin(), order.end(), size_t(0));
    const size_t top = std::min<size_t>(order.size(), 2000);
    std::partial_sort(order.begin(), order.begin() + top, order.end(),
                      [&](size_t a, size_t b) { return score[a] > score[b]; });
    for (size_t t = 0; t < top && int(picked.size() - first) < want; ++t) {
      const size_t id = order[t];
      if (!(score[id] > 0)) break;
      const int r = int(id % nr) + r0, x = int(id / nr % (lw + 1)), y = int(id / nr / (lw + 1));
      bool near = false;
      // Apart from this kind's picks; a later kind also skips what an earlier one took.
      for (size_t q = kind == 2 ? 0 : first; q < picked.size(); ++q) {
        const auto& p = picked[q];
        if (std::abs(p[0] - x) <= 3 && std::abs(p[1] - y) <= 3 && std::abs(p[2] - r) <= 3) near = true;
      }
      if (near) continue;
      picked.push_back({x, y, r});
      out.push_back({{x * L.sx, y * L.sy, r * L.s()}, whole});
    }
  }
  return out;
}

// Circles found by OpenCV's Hough transform (HOUGH_GRADIENT_ALT, on the compressed
// luminance at most 800 px across; where that finds none, on its equalised histogram), best
// supported first, at most `keep`, in full-res coordinates: seeds placed by the rim's own
// edges to a pixel or two, that skip the region search. In an uncropped photo the region
// search from a coarse seed converged inside the ball (a circle 30 px small and 34 px off on
// grace at frame 2.3), out of the rim fit's reach.
std::vector<Circle> hough_seeds(const cv::Mat& col, double r_min, double r_max, int keep) {
  const int w = col.cols, h = col.rows;
  const double f = std::max(1.0, std::max(w, h) / 800.0);
  cv::Mat grey, small, g8;
  cv::cvtColor(col, grey, cv::COLOR_RGB2GRAY);
  if (f > 1)
    cv::resize(grey, small, cv::Size(std::max(16, int(std::lround(w / f))), std::max(16, int(std::lround(h / f)))), 0, 0,
               cv::INTER_AREA);
  else
    small = grey;
  small.convertTo(g8, CV_8U, 255.0);
  // Canny's high threshold 100 on codes of the compressed luminance (300, OpenCV's suggestion
  // for contrasty photos, found no circle on a studio ball in front of Memorial), and a
  // perfectness of 0.6: the rim fit decides among what these let through. Where that finds
  // no circle, the same on the histogram-equalised codes: a dark rim against a dim
  // background (the studio ball's black reflections before Memorial's grey walls, uncropped
  // at R 150) has too little contrast in the compressed codes, and equalising spreads the
  // dark codes apart (found at every threshold tried, 0.01 px after the rim fit). Not beside
  // the first pass's circles: on grace they moved the pick by 0.26 px.
  std::vector<cv::Vec4f> found;  // x, y, r, votes
  const auto hough = [&](const cv::Mat& codes) {
    cv::HoughCircles(codes, found, cv::HOUGH_GRADIENT_ALT, 1.5, std::max(8.0, r_min / f), 100, 0.6,
                     int(std::floor(r_min / f)), int(std::ceil(r_max / f)));
  };
  hough(g8);
  if (found.empty()) {
    cv::Mat equalised;
    cv::equalizeHist(g8, equalised);
    hough(equalised);
  }
  std::stable_sort(found.begin(), found.end(), [](const cv::Vec4f& a, const cv::Vec4f& b) { return a[3] > b[3]; });
  std::vector<Circle> out;
  const double sx = double(w) / small.cols, sy = double(h) / small.rows;
  for (const cv::Vec4f& c : found) {
    if (int(out.size()) >= keep) break;
    out.push_back({(c[0] + 0.5) * sx, (c[1] + 0.5) * sy, c[2] * std::sqrt(sx * sy)});
  }
  return out;
}

}  // namespace

// A rim fit counts when at least this share of its rays has an edge on it (clean renders
// 0.7-1; the kartik photos' blurred rims 0.2-0.35, like random circles in texture).
constexpr double kMinRimAgreement = 0.5;

BallInImage find_ball(const RgbImage& image, const FindBallOptions& options, FindBallReport* report) {
  const int w = image.width, h = image.height;
  if (w < 16 || h < 16 || image.rgb.size() != size_t(3) * w * h)
    throw InputError("find_ball: the image is empty or smaller than 16 x 16");
  if (options.rays < 16) throw InputError("find_ball: need at least 16 rays");
  if (!image.valid.empty() && image.valid.size() != size_t(w) * h)
    throw InputError("find_ball: the validity mask does not match the image size");
  // Compressed colour c / (c + mean luminance), so that HDR highlights do not dominate.
  double mean = 0;
  size_t n_valid = 0;
  for (size_t i = 0; i < size_t(w) * h; ++i) {
    if (!image.valid.empty() && !image.valid[i]) continue;
    ++n_valid;
    const float* p = &image.rgb[3 * i];
    const float l = luminance(p[0], p[1], p[2]);
    if (std::isfinite(l) && l > 0) mean += l;
  }
  mean /= std::max<double>(1, n_valid);
  if (!(mean > 0)) throw InputError("find_ball: no ball found (the image is black)");
  cv::Mat col(h, w, CV_32FC3), lin(h, w, CV_32FC3), lum(h, w, CV_32F), valid01(h, w, CV_32F), valid8(h, w, CV_8U);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const size_t i = size_t(y) * w + x;
      const float* p = &image.rgb[3 * i];
      cv::Vec3f v, u;
      for (int c = 0; c < 3; ++c) {
        const double q = std::isfinite(p[c]) ? std::max(0.0f, p[c]) : 0.0;
        v[c] = float(q / (q + mean));
        u[c] = float(q / mean);
      }
      col.at<cv::Vec3f>(y, x) = v;
      lin.at<cv::Vec3f>(y, x) = u;
      lum.at<float>(y, x) = float(0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2]);
      const bool ok = image.valid.empty() || image.valid[i];
      valid01.at<float>(y, x) = ok ? 1.f : 0.f;
      valid8.at<uint8_t>(y, x) = ok ? 1 : 0;
    }
  cv::Mat fine, lum_blur, energy;
  // Sub-pixel passes run on linear values: the rim's pixels blend ball and background
  // linearly in radiance, and any compression would move the edge towards the dark side.
  cv::GaussianBlur(lin, fine, cv::Size(0, 0), 1.0);
  // Texture: local high-frequency energy of the compressed luminance.
  // (the residual of a 3 x 3 median: speckle and fine texture, but not a step edge).
  cv::medianBlur(lum, lum_blur, 3);
  cv::absdiff(lum, lum_blur, energy);
  cv::GaussianBlur(energy, energy, cv::Size(0, 0), 1.5);
  lum.release(), lum_blur.release();  // full-resolution buffers add up on a camera's 15-25 Mpx

  const double min_dim = std::min(w, h);
  const double r_min = options.min_radius_fraction * min_dim, r_max = options.max_radius_fraction * min_dim;

  // Pyramid: factors 1, 2, 4, ... up to the coarsest level at most 64 px across; the
  // analysis level (confidence, choice between seeds) is the one at most 128 px across.
  std::vector<int> factors{1};
  while (std::max(w, h) / factors.back() > 64) factors.push_back(2 * factors.back());
  int analysis = 0;
  while (analysis + 1 < int(factors.size()) && std::max(w, h) / factors[analysis] > 128) ++analysis;
  // The full-resolution level serves only the region answer's last refinement, which a
  // sub-pixel rim fit replaces: built when that answer is needed (a quarter of the
  // pyramid's cost and a 33 MB allocation at 1920 x 1080).
  std::vector<FeatureLevel> levels(factors.size());
  for (size_t i = 0; i < factors.size(); ++i)
    if (i > 0 || factors.size() == 1 || analysis == 0) levels[i] = make_level(col, energy, valid01, factors[i]);

  std::vector<std::pair<Circle, bool>> seeds;  // circle, whole (seeded by score_whole)
  size_t first_hough = std::numeric_limits<size_t>::max();  // seeds from here on skip the region search
  if (options.initial_guess) {
    seeds.push_back({{options.initial_guess->cx, options.initial_guess->cy, options.initial_guess->radius_px}, false});
  } else {
    seeds = coarse_seeds(levels.back(), r_min, r_max, 8, 4, 4, options.max_cut_fraction);
    first_hough = seeds.size();
    for (const Circle& c : hough_seeds(col, r_min, r_max, 4)) seeds.push_back({c, true});
  }

  // Each seed refined on the region contrast, then its silhouette fitted; the circle whose
  // fitted rim agrees with the edges along the longest arc wins (a large circle half
  // outside the image or through a textured background agrees along little of it). Where
  // no fit agrees along kMinRimAgreement of the rim (a blurred photo whose rim fades into
  // a similar background: 0.2-0.35 on the kartik frames) the region score decides and
  // its answer stands.
  struct Pick {
    Circle c;
    RegionScore s;
    RimFit rim;
    bool in_view = true;  // its rim fit is cut by the border no more than max_cut_fraction
  };
  std::optional<Pick> best;
  auto arc = [](const Pick& p) {
    return p.rim.ok && p.rim.agreement >= kMinRimAgreement ? p.rim.agreement * p.rim.ball.radius_px : -1.0;
  };
  // Seeds refined down to level 1 (half resolution) only: the rim fit's first window
  // covers the difference, and the winner's region answer is refined on level 0 below.
  const int last_level = levels.size() > 1 ? 1 : 0;
  const double edge_noise = edge_noise_level(fine, valid8);
  const bool near_guess = options.initial_guess && options.initial_guess_reach_px > 0;
  for (size_t si = 0; si < seeds.size(); ++si) {
    auto [c, whole] = seeds[si];
    if (si < first_hough)
      for (int li = int(levels.size()) - 1; li >= last_level; --li)
        if (!near_guess || 2 * factors[size_t(li)] <= options.initial_guess_reach_px)
          c = local_search(levels[li], c, r_min, r_max, options.max_cut_fraction, whole);
    Pick p{c, region_score(levels[analysis], c, angles_for(levels[analysis], c), options.max_cut_fraction), {}};
    auto near = [](const RimFit& fit, const Circle& from) {
      return std::hypot(fit.ball.cx - from.cx, fit.ball.cy - from.cy) <= 8 + 0.02 * from.r &&
             std::abs(fit.ball.radius_px - from.r) <= 8 + 0.02 * from.r;
    };
    p.rim = fit_rim(fine, lin, valid8, {c.cx, c.cy, c.r}, options.rays, edge_noise);
    // A rim that agrees along most of its length but lies beyond the search window's reach
    // of the region answer (a ball whose lower rim has little contrast against the ground
    // pulls the region answer 12 px up) is fitted again from where it was found: held if it
    // stays there.
    for (int again = 0; again < 2 && !near(p.rim, c) && p.rim.agreement >= kMinRimAgreement; ++again) {
      const Circle moved{p.rim.ball.cx, p.rim.ball.cy, p.rim.ball.radius_px};
      RimFit refit = fit_rim(fine, lin, valid8, {moved.cx, moved.cy, moved.r}, options.rays, edge_noise);
      if (!(refit.agreement >= kMinRimAgreement)) break;
      p.rim = std::move(refit);
      c = p.c = moved;
      // The confidence and the tie-break read the region score: the moved circle's.
      p.s = region_score(levels[analysis], c, angles_for(levels[analysis], c), options.max_cut_fraction);
    }
    if (!near(p.rim, c)) p.rim.ok = false;
    // A rim fit that would be rejected as cut by the border loses to any that would not:
    // large circles half outside the image collect arcs of texture along their visible
    // half and outscored (agreement x radius) the ball wholly in view, then find_ball
    // threw. Without a rim fit held in view the order is as before.
    p.in_view = cut_fraction({p.rim.ball.cx, p.rim.ball.cy, p.rim.ball.radius_px}, w, h) <= options.max_cut_fraction;
    auto held = [&](const Pick& q) { return arc(q) > 0 && q.in_view; };
    if (!best || (held(p) != held(*best) ? held(p)
                  : arc(p) > arc(*best) || (arc(p) == arc(*best) && p.s.score > best->s.score)))
      best = p;
  }
  const double confidence = best && best->s.visible >= 0.25 ? best->s.support : 0.0;
  if (!best || confidence < options.min_confidence)
    throw InputError("find_ball: no ball found (boundary confidence " + std::to_string(confidence).substr(0, 4) +
                     " < " + std::to_string(options.min_confidence).substr(0, 4) + ")");
  Circle result = best->c;
  FindBallReport rep;
  // Above 4 Mpx the half-resolution answer stands: it is good to a pixel or two, and the
  // full-resolution level would cost about a second and 1 GB at 15 Mpx for less than that.
  const bool full_level_affordable = double(w) * h <= 4.2e6;
  if (!(arc(*best) > 0) && last_level && full_level_affordable) {
    if (levels[0].feat.empty()) levels[0] = make_level(col, energy, valid01, 1);
    result = local_search(levels[0], best->c, r_min, r_max, options.max_cut_fraction);
  }
  if (arc(*best) > 0) {
    // Only the winner: the coverage model costs tens of milliseconds per fit.
    const RimFit rim = refine_rim_by_coverage(lin, valid8, best->rim, edge_noise);
    rep.subpixel = true;
    result = {rim.ball.cx, rim.ball.cy, rim.ball.radius_px};
    rep.rms_residual_px = rim.rms_px, rep.edge_points = rim.inliers;
    rep.sigma_centre_px = rim.sigma_centre_px, rep.sigma_radius_px = rim.sigma_radius_px;
    rep.noise_sigma_centre_px = rim.noise_sigma_centre_px, rep.noise_sigma_radius_px = rim.noise_sigma_radius_px;
    rep.rim_agreement = rim.agreement, rep.inner_rim_dropped = rim.inner_rim_dropped;
  }
  rep.confidence = confidence;
  rep.cut_fraction = cut_fraction(result, w, h);
  if (report) *report = rep;
  if (!(result.r >= options.min_radius_px))
    throw InputError(fmt::format("find_ball: the circle found is {:.1f} px in radius, below {:g} px: too small to "
                                 "unwrap (is there a ball in this image?)",
                                 result.r, options.min_radius_px));
  if (rep.cut_fraction > options.max_cut_fraction && !rep.subpixel)
    throw InputError(fmt::format(
        "find_ball: no ball found wholly in view: the likeliest circle, ({:.0f}, {:.0f}) r {:.0f} px, has no clear rim "
        "and {:.0f} % of it lies outside the image (balls below {:.0f} px radius, {:g} of the short side, are not "
        "searched); give the ball with --ball cx,cy,r",
        result.cx, result.cy, result.r, 100 * rep.cut_fraction, r_min, options.min_radius_fraction));
  if (rep.cut_fraction > options.max_cut_fraction)
    throw InputError("find_ball: ball cut by the image border (" + std::to_string(int(std::round(100 * rep.cut_fraction))) +
                     " % of its rim outside, max_cut_fraction allows " +
                     std::to_string(int(std::round(100 * options.max_cut_fraction))) + " %)");
  return {result.cx, result.cy, result.r};
}

std::string ball_fit_warning(const FindBallReport& r) {
  const int pct = int(std::lround(100 * r.rim_agreement));
  if (!r.subpixel)
    return "no sub-pixel rim fit held; the ball is the region answer, good to a few pixels where the rim stands out "
           "and off by more where it does not (a ball pasted on a canvas, a rim on a like background): check it, or give "
           "--ball cx,cy,r";
  if (r.rim_agreement < kPartialRimAgreement)
    return "the ball's rim has an edge along only " + std::to_string(pct) +
           " % of its circumference (dark on dark?): centre and radius rest on that arc" +
           (r.inner_rim_dropped ? ", a circle inside it set aside" : "") +
           "; they may be off by more than the sigmas if the rest of the rim is not where the arc puts it";
  return {};
}

// ---------------------------------------------------------------------------------------
// Unwrapping

RemapTable mirror_ball_remap(const BallInImage& ball, const MirrorBallCamera& camera, int image_width,
                             int image_height, Layout layout, int width, int height,
                             const MirrorBallRemapOptions& options) {
  if (image_width <= 0 || image_height <= 0) throw InputError("mirror ball: image size must be positive");
  if (!(options.blind_spot_deg >= 0 && options.blind_spot_deg < 180))
    throw InputError("mirror ball: blind_spot_deg must be in [0, 180)");
  const MirrorBallProjection proj(ball, camera, image_width);
  const double max_psi = std::min(M_PI - options.blind_spot_deg * M_PI / 180, proj.max_reflection_angle());
  const double max_r = ball.radius_px - options.rim_margin_px;
  return remap_table(layout, width, height, image_width, image_height,
                     [&](Vec3 d) -> std::optional<std::array<double, 2>> {
                       if (proj.reflection_angle(d) > max_psi) return std::nullopt;
                       const auto pt = proj.image_point(d);
                       if (!pt || std::hypot((*pt)[0] - ball.cx, (*pt)[1] - ball.cy) > max_r) return std::nullopt;
                       return pt;
                     });
}

namespace {

// Push-pull fill of a row grid (latlong wraps in azimuth) in place; only invalid pixels change.
void fill_grid(std::vector<float>& rgb, const std::vector<uint8_t>& valid, int w, int h, bool wrap) {
  struct Level {
    int w, h;
    std::vector<float> rgb;  // 3 per pixel
    std::vector<float> wt;   // coverage in [0, 1]
  };
  std::vector<Level> levels;
  Level l0{w, h, rgb, std::vector<float>(size_t(w) * h)};
  for (size_t i = 0; i < l0.wt.size(); ++i) l0.wt[i] = valid[i] ? 1.f : 0.f;
  levels.push_back(std::move(l0));
  while (levels.back().w > 1 || levels.back().h > 1) {
    const Level& f = levels.back();
    Level c{(f.w + 1) / 2, (f.h + 1) / 2, {}, {}};
    c.rgb.assign(3 * size_t(c.w) * c.h, 0.f);
    c.wt.assign(size_t(c.w) * c.h, 0.f);
    for (int y = 0; y < c.h; ++y)
      for (int x = 0; x < c.w; ++x) {
        double s[3] = {0, 0, 0}, ws = 0;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            const int fx = 2 * x + dx, fy = 2 * y + dy;
            if (fx >= f.w || fy >= f.h) continue;
            const size_t j = size_t(fy) * f.w + fx;
            ws += f.wt[j];
            for (int ch = 0; ch < 3; ++ch) s[ch] += f.wt[j] * f.rgb[3 * j + ch];
          }
        const size_t i = size_t(y) * c.w + x;
        if (ws > 0)
          for (int ch = 0; ch < 3; ++ch) c.rgb[3 * i + ch] = float(s[ch] / ws);
        c.wt[i] = float(std::min(1.0, ws));
      }
    levels.push_back(std::move(c));
  }
  // Pull: from coarse to fine, pixels with weight < 1 blend in the upsampled coarser level.
  for (int li = int(levels.size()) - 2; li >= 0; --li) {
    Level& f = levels[li];
    const Level& c = levels[li + 1];
    for (int y = 0; y < f.h; ++y)
      for (int x = 0; x < f.w; ++x) {
        const size_t i = size_t(y) * f.w + x;
        if (f.wt[i] >= 1) continue;
        // Bilinear upsampling: fine centre (x + 0.5) sits at coarse coordinate (x + 0.5) / 2 - 0.5.
        const double cxf = (x + 0.5) / 2 - 0.5, cyf = (y + 0.5) / 2 - 0.5;
        int x0 = int(std::floor(cxf)), y0 = int(std::floor(cyf));
        const double ax = cxf - x0, ay = cyf - y0;
        double up[3] = {0, 0, 0};
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            int xx = x0 + dx, yy = std::clamp(y0 + dy, 0, c.h - 1);
            xx = wrap ? ((xx % c.w) + c.w) % c.w : std::clamp(xx, 0, c.w - 1);
            const double wgt = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
            const size_t j = size_t(yy) * c.w + xx;
            for (int ch = 0; ch < 3; ++ch) up[ch] += wgt * c.rgb[3 * j + ch];
          }
        const double a = f.wt[i];
        for (int ch = 0; ch < 3; ++ch) f.rgb[3 * i + ch] = float(a * f.rgb[3 * i + ch] + (1 - a) * up[ch]);
      }
  }
  for (size_t i = 0; i < valid.size(); ++i)
    if (!valid[i])
      for (int ch = 0; ch < 3; ++ch) rgb[3 * i + ch] = levels[0].rgb[3 * i + ch];
}

// Push-pull on a NESTED healpix map: parents are groups of four consecutive indices.
void fill_healpix(std::vector<float>& rgb, const std::vector<uint8_t>& valid) {
  std::vector<std::vector<float>> vals{rgb};
  std::vector<std::vector<float>> wts{std::vector<float>(valid.size())};
  for (size_t i = 0; i < valid.size(); ++i) wts[0][i] = valid[i] ? 1.f : 0.f;
  while (vals.back().size() / 3 > 12) {
    const auto& fv = vals.back();
    const auto& fw = wts.back();
    const size_t n = fw.size() / 4;
    std::vector<float> cv(3 * n, 0.f), cw(n, 0.f);
    for (size_t p = 0; p < n; ++p) {
      double s[3] = {0, 0, 0}, ws = 0;
      for (size_t c = 4 * p; c < 4 * p + 4; ++c) {
        ws += fw[c];
        for (int ch = 0; ch < 3; ++ch) s[ch] += fw[c] * fv[3 * c + ch];
      }
      if (ws > 0)
        for (int ch = 0; ch < 3; ++ch) cv[3 * p + ch] = float(s[ch] / ws);
      cw[p] = float(std::min(1.0, ws));
    }
    vals.push_back(std::move(cv));
    wts.push_back(std::move(cw));
  }
  // Base pixels with nothing valid take the mean of the valid base pixels.
  {
    auto& bv = vals.back();
    auto& bw = wts.back();
    double s[3] = {0, 0, 0}, ws = 0;
    for (size_t p = 0; p < bw.size(); ++p) {
      ws += bw[p];
      for (int ch = 0; ch < 3; ++ch) s[ch] += bw[p] * bv[3 * p + ch];
    }
    for (size_t p = 0; p < bw.size(); ++p)
      if (bw[p] < 1 && ws > 0)
        for (int ch = 0; ch < 3; ++ch) bv[3 * p + ch] = float(bw[p] * bv[3 * p + ch] + (1 - bw[p]) * s[ch] / ws);
  }
  for (int li = int(vals.size()) - 2; li >= 0; --li) {
    auto& fv = vals[li];
    const auto& fw = wts[li];
    const auto& cv = vals[li + 1];
    for (size_t i = 0; i < fw.size(); ++i)
      if (fw[i] < 1)
        for (int ch = 0; ch < 3; ++ch) fv[3 * i + ch] = fw[i] * fv[3 * i + ch] + (1 - fw[i]) * cv[3 * (i / 4) + ch];
  }
  for (size_t i = 0; i < valid.size(); ++i)
    if (!valid[i])
      for (int ch = 0; ch < 3; ++ch) rgb[3 * i + ch] = vals[0][3 * i + ch];
}

}  // namespace

EnvMap unwrap_mirror_ball(const RgbImage& image, const BallInImage& ball, const MirrorBallCamera& camera,
                          Layout layout, int width, int height, const UnwrapOptions& options,
                          UnwrapReport* report) {
  if (image.width < 2 || image.height < 2 || image.rgb.size() != size_t(3) * image.width * image.height)
    throw InputError("unwrap mirror ball: the image is empty");
  if (options.samples_per_edge < 0 || options.samples_per_edge > 64)
    throw InputError("unwrap mirror ball: samples_per_edge must be in [0, 64]");
  const MirrorBallProjection proj(ball, camera, image.width);
  EnvMap out = make_envmap(layout, width, height);
  out.units = image.units;
  out.world_from_probe = camera.world_from_probe;

  // Sub-samples per edge.
  int k = options.samples_per_edge;
  if (k == 0) {
    const double out_angle = std::sqrt(layout_solid_angle(layout) / double(out.pixel_count()));
    k = std::clamp(int(std::ceil(out_angle / (2 / ball.radius_px) - 1e-9)), 1, 8);
  }
  if (layout == Layout::Healpix) {
    int p = 1;
    while (p < k) p *= 2;
    k = p;
  }
  const int fw = layout == Layout::Healpix ? out.nside * k : width * k;
  const int fh = layout == Layout::Healpix ? 0 : height * k;
  const RemapTable table = mirror_ball_remap(ball, camera, image.width, image.height, layout, fw, fh,
                                             {options.blind_spot_deg, options.rim_margin_px});
  const RgbImage sampled = apply_remap(image, table);
  const EnvMap fine = make_envmap(layout, fw, fh);

  // Downsample with solid-angle weights over valid sub-samples.
  const size_t n = out.pixel_count();
  out.valid.assign(n, 0);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 256), [&](const tbb::blocked_range<size_t>& range) {
    std::vector<size_t> subs(size_t(k) * k);
    for (size_t i = range.begin(); i != range.end(); ++i) {
      if (layout == Layout::Healpix) {
        for (size_t s = 0; s < subs.size(); ++s) subs[s] = i * subs.size() + s;
      } else {
        const size_t u = i % width, v = i / width;
        for (int j = 0; j < k; ++j)
          for (int q = 0; q < k; ++q) subs[size_t(j) * k + q] = (v * k + j) * size_t(fw) + u * k + q;
      }
      double sum[3] = {0, 0, 0}, wv = 0, wall = 0;
      for (size_t s : subs) {
        const double om = pixel_solid_angle(fine, s);
        wall += om;
        if (!(sampled.valid.empty() || sampled.valid[s])) continue;
        if (std::isnan(table.src_x[s])) continue;
        double scale = 1;
        if (options.compensate_reflectivity) {
          const auto hit = proj.hit(table.src_x[s], table.src_y[s]);
          scale = 1 / proj.reflectivity(hit ? hit->cos_incidence : 0.0);
        }
        wv += om;
        for (int c = 0; c < 3; ++c) sum[c] += om * scale * sampled.rgb[3 * s + c];
      }
      if (wv > 0 && wv >= options.min_valid_fraction * wall) {
        out.valid[i] = 1;
        for (int c = 0; c < 3; ++c) out.rgb[3 * i + c] = float(sum[c] / wv);
      }
    }
  });

  double valid_omega = 0, valid_power = 0;
  for (size_t i = 0; i < n; ++i)
    if (out.valid[i]) {
      const double om = pixel_solid_angle(out, i);
      valid_omega += om;
      valid_power += om * luminance(out.pixel(i)[0], out.pixel(i)[1], out.pixel(i)[2]);
    }
  double fill_share = 0;
  if (options.fill && valid_omega > 0) {
    if (layout == Layout::Healpix)
      fill_healpix(out.rgb, out.valid);
    else
      fill_grid(out.rgb, out.valid, width, height, layout == Layout::LatLong || layout == Layout::Hemisphere);
    double fill_power = 0;
    for (size_t i = 0; i < n; ++i)
      if (!out.valid[i])
        fill_power += pixel_solid_angle(out, i) * luminance(out.pixel(i)[0], out.pixel(i)[1], out.pixel(i)[2]);
    fill_share = fill_power + valid_power > 0 ? fill_power / (fill_power + valid_power) : 0;
  }
  if (report) *report = {k, valid_omega / layout_solid_angle(layout), fill_share};
  return out;
}

}  // namespace lp
