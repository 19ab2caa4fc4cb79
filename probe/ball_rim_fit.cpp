#include "probe/ball_rim_fit.h"

#include "probe/ball_rim_coverage.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <optional>

namespace lp {

cv::Vec3f bilinear3(const cv::Mat& img, double x, double y) {
  const double fx = x - 0.5, fy = y - 0.5;
  int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  x0 = std::clamp(x0, 0, img.cols - 2);
  y0 = std::clamp(y0, 0, img.rows - 2);
  const float ax = float(fx - x0), ay = float(fy - y0);
  const cv::Vec3f* r0 = img.ptr<cv::Vec3f>(y0);
  const cv::Vec3f* r1 = img.ptr<cv::Vec3f>(y0 + 1);
  return (1 - ay) * ((1 - ax) * r0[x0] + ax * r0[x0 + 1]) + ay * ((1 - ax) * r1[x0] + ax * r1[x0 + 1]);
}

std::vector<RimEdge> radial_edges(const cv::Mat& img, double cx, double cy, double theta, double r_lo, double r_hi,
                                  int keep, double step) {
  const double dx = std::cos(theta), dy = std::sin(theta);
  const double w = img.cols, h = img.rows;
  // Derivatives over a 1 px baseline (bilinear samples have piecewise-constant slopes
  // within a pixel, so a shorter baseline would quantise the peak to pixel cells); peak
  // refined by a parabola through the derivative at -1, 0, +1 px.
  const int half = int(std::lround(0.5 / step)), reach = 2 * half;
  // The step's two sides for its relative contrast, 1.5 px either way (past the blur).
  const int side = int(std::lround(1.5 / step)), margin = std::max(reach + 1, side);
  const double lo = std::max(0.0, r_lo - margin * step), hi = r_hi + margin * step;
  for (double rr : {lo, hi}) {
    const double x = cx + rr * dx, y = cy + rr * dy;
    if (x < 0.5 || y < 0.5 || x > w - 0.5 || y > h - 0.5) return {};
  }
  const int n = int(std::ceil((hi - lo) / step)) + 1;
  if (n < 2 * reach + 5) return {};
  std::vector<cv::Vec3f> p(n);
  std::vector<double> d(n, 0.0);
  for (int i = 0; i < n; ++i) p[i] = bilinear3(img, cx + (lo + i * step) * dx, cy + (lo + i * step) * dy);
  for (int i = half; i + half < n; ++i) {
    const cv::Vec3f g = p[i + half] - p[i - half];
    d[i] = (std::abs(g[0]) + std::abs(g[1]) + std::abs(g[2])) / (2 * half * step);
  }
  std::vector<RimEdge> out;
  for (int i = reach + half; i + reach + half < n; ++i) {
    if (!(d[i] > d[i - 1] && d[i] >= d[i + 1])) continue;
    const double dm = d[i - reach], dp = d[i + reach];
    const double denom = dm - 2 * d[i] + dp;
    const double off = denom < 0 ? std::clamp(0.5 * (dm - dp) / denom, -0.5, 0.5) * reach : 0.0;
    const double rr = lo + (i + off) * step;
    if (rr < r_lo || rr > r_hi) continue;
    const cv::Vec3f& a = p[std::max(0, i - side)];
    const cv::Vec3f& b = p[std::min(n - 1, i + side)];
    const double inner = a[0] + a[1] + a[2], outer = b[0] + b[1] + b[2], level = std::max(inner, outer);
    out.push_back({cx + rr * dx, cy + rr * dy, d[i], level > 0 ? std::abs(inner - outer) / level : 0.0});
  }
  std::sort(out.begin(), out.end(), [](const RimEdge& a, const RimEdge& b) { return a.strength > b.strength; });
  if (int(out.size()) > keep) out.resize(keep);
  return out;
}

namespace {

double ray_angle(int k, int rays) { return 2 * M_PI * (k + 0.5) / rays; }

double residual(const RimEdge& p, const BallInImage& c) { return std::hypot(p.x - c.cx, p.y - c.cy) - c.radius_px; }

// Per ray, the edges within +-window of circle c, strongest first; empty where the band
// leaves the image or touches an invalid pixel.
using RayEdges = std::vector<std::vector<RimEdge>>;

// Whether ray k's band of +-window around c lies inside the image on valid pixels.
bool ray_in_view(const cv::Mat& img, const cv::Mat& valid8, const BallInImage& c, double window, int k, int rays) {
  const double t = ray_angle(k, rays), ct = std::cos(t), st = std::sin(t);
  for (double rr = c.radius_px - window - 2; rr <= c.radius_px + window + 2; rr += 1) {
    const double x = c.cx + rr * ct, y = c.cy + rr * st;
    if (x < 0.5 || y < 0.5 || x > img.cols - 0.5 || y > img.rows - 0.5) return false;
    if (!valid8.empty() && !valid8.at<uint8_t>(int(y), int(x))) return false;
  }
  return true;
}

RayEdges ray_edges(const cv::Mat& img, const cv::Mat& valid8, const BallInImage& c, double window, int rays) {
  RayEdges out(rays);
  tbb::parallel_for(0, rays, [&](int k) {
    if (!ray_in_view(img, valid8, c, window, k, rays)) return;
    out[k] = radial_edges(img, c.cx, c.cy, ray_angle(k, rays), c.radius_px - window, c.radius_px + window, 64);
  });
  return out;
}

struct Weighted {
  RimEdge e;
  double w;  // relative strength in (0, 1]
};

double median_of(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

// Whether an edge counts: at least 10 % as strong as the median ray's strongest, or a
// step whose darker side is less than kDarkStep of its brighter one and which stands
// clear of the noise (a dark reflection at the rim against a dark background: weak in
// absolute terms, yet the ball's silhouette).
constexpr double kDarkStep = 0.5;
bool counts(const RimEdge& e, double floor, double noise) {
  return e.strength >= floor || (e.rel >= kDarkStep && e.strength > noise);
}

// An edge's weight in the circle fit: its strength relative to the median ray's (`med`),
// or, for a dark step (as in counts), its strength against the noise: such an edge is
// placed as precisely as a bright one where the noise allows, and weighting it by its
// absolute strength would leave the dark arc to the bright one's fit.
double edge_weight(double strength, double rel, double med, double noise) {
  double w = std::min(1.0, strength / med);
  if (rel >= kDarkStep && strength > noise) w = std::max(w, noise > 0 ? std::min(1.0, strength / (2 * noise)) : 1.0);
  return w;
}

// Per ray, the outermost edge (or the strongest) that counts.
std::vector<Weighted> pick_edges(const RayEdges& cands, const BallInImage& c, bool strongest, double noise) {
  std::vector<double> tops;
  for (const auto& ray : cands)
    if (!ray.empty()) tops.push_back(ray[0].strength);
  if (tops.empty()) return {};
  const double med = median_of(tops), floor = 0.1 * med;
  std::vector<Weighted> pts;
  for (const auto& ray : cands) {
    const RimEdge* best = nullptr;
    for (const auto& e : ray)
      if (counts(e, floor, noise) && (!best || (!strongest && residual(e, c) > residual(*best, c)))) best = &e;
    if (best) pts.push_back({*best, edge_weight(best->strength, best->rel, med, noise)});
  }
  return pts;
}

struct FitResult {
  BallInImage c;
  cv::Matx33d cov;
  double rms = 0;
  int inliers = 0;
};

// Gauss-Newton with Tukey biweights times the edges' relative strength.
FitResult robust_circle(const std::vector<Weighted>& pts, BallInImage c) {
  std::vector<double> absr(pts.size());
  FitResult f;
  for (int outer = 0; outer < 6; ++outer) {
    for (size_t i = 0; i < pts.size(); ++i) absr[i] = std::abs(residual(pts[i].e, c));
    std::nth_element(absr.begin(), absr.begin() + absr.size() / 2, absr.end());
    const double k = 4.685 * std::max(0.03, 1.4826 * absr[absr.size() / 2]);
    cv::Matx33d jtj;
    cv::Vec3d jtr;
    double swr2 = 0, sw = 0;
    int n = 0;
    for (const Weighted& p : pts) {
      const double dx = p.e.x - c.cx, dy = p.e.y - c.cy, dist = std::hypot(dx, dy), ri = dist - c.radius_px;
      if (dist < 1e-9 || std::abs(ri) >= k) continue;
      const double u = ri / k, wgt = p.w * (1 - u * u) * (1 - u * u);
      const cv::Vec3d j(-dx / dist, -dy / dist, -1);
      jtj += wgt * j * j.t();
      jtr += wgt * ri * j;
      swr2 += wgt * ri * ri, sw += wgt, ++n;
    }
    cv::Vec3d delta;
    if (n < 6 || !cv::solve(jtj, -jtr, delta, cv::DECOMP_CHOLESKY)) return f;
    c.cx += delta[0], c.cy += delta[1], c.radius_px += delta[2];
    f.c = c, f.inliers = n, f.rms = std::sqrt(swr2 / sw);
    // Weights normalised to a mean of 1 over the inliers, so that s^2 is a per-edge variance.
    f.cov = (swr2 / std::max(1.0, sw - 3 * sw / n)) * jtj.inv();
  }
  return f;
}

// Per ray, the silhouette by area: with A = the profile 1.5 px inside the circle and B =
// 1.5 px outside, the edge sits at r - 1.5 + integral over [r - 1.5, r + 1.5] of
// (p - B) / (A - B): exact for a step blurred by pixel coverage and bilinear
// interpolation, and an error of either sign (not always inwards, as a derivative peak
// merged with the rings just inside is) where the rim's last pixel differs from A.
// Weight: |A - B| relative to the median ray's, capped at 1.
std::vector<Weighted> area_edges(const cv::Mat& img, const cv::Mat& valid8, const BallInImage& c, int rays,
                                 double noise) {
  constexpr double half = 1.5, step = 0.125;
  std::vector<Weighted> pts(rays, {{0, 0, 0}, -1});
  tbb::parallel_for(0, rays, [&](int k) {
    const double t = ray_angle(k, rays), ct = std::cos(t), st = std::sin(t);
    const double lo = c.radius_px - half, hi = c.radius_px + half;
    for (double rr : {lo - 2, hi + 2}) {
      const double x = c.cx + rr * ct, y = c.cy + rr * st;
      if (x < 0.5 || y < 0.5 || x > img.cols - 0.5 || y > img.rows - 0.5) return;
      if (!valid8.empty() && !valid8.at<uint8_t>(int(y), int(x))) return;
    }
    auto at = [&](double rr) { return bilinear3(img, c.cx + rr * ct, c.cy + rr * st); };
    const cv::Vec3f a = at(lo), b = at(hi), ab = a - b;
    const double den = ab.dot(ab);
    if (!(den > 0)) return;
    double area = 0;
    const int n = int(std::lround((hi - lo) / step));
    for (int i = 0; i < n; ++i) {
      const double f = (at(lo + (i + 0.5) * step) - b).dot(ab) / den;
      area += std::clamp(f, -0.5, 1.5) * step;
    }
    const double e = lo + area;
    const double sa = a[0] + a[1] + a[2], sb = b[0] + b[1] + b[2], level = std::max(sa, sb);
    pts[k] = {{c.cx + e * ct, c.cy + e * st, std::sqrt(den), level > 0 ? std::abs(sa - sb) / level : 0.0}, 1};
  });
  std::vector<Weighted> out;
  std::vector<double> s;
  for (const auto& p : pts)
    if (p.w > 0) out.push_back(p), s.push_back(p.e.strength);
  if (out.empty()) return out;
  const double med = median_of(s);
  // A and B are unsmoothed samples, about 4 x noisier than the smoothed differences
  // `noise` was measured on (three channels, two samples, no Gaussian of 1 px).
  for (auto& p : out) p.w = edge_weight(p.e.strength, p.e.rel, med, 4 * noise);
  return out;
}

}  // namespace

namespace {

// Windows of 3, 2, 1.5, 1 px around c, the outermost edges; nullopt when the fit fails
// or runs away (more than two windows).
std::optional<BallInImage> narrow(const cv::Mat& smooth, const cv::Mat& valid8, BallInImage c, int rays, double noise) {
  for (const double window : {3.0, 2.0, 1.5, 1.0}) {
    const auto pts = pick_edges(ray_edges(smooth, valid8, c, window, rays), c, false, noise);
    if (pts.size() < 12) return std::nullopt;
    const FitResult f = robust_circle(pts, c);
    if (f.inliers == 0 || !(f.c.radius_px > 0)) return std::nullopt;
    if (std::hypot(f.c.cx - c.cx, f.c.cy - c.cy) > 2 * window || std::abs(f.c.radius_px - c.radius_px) > 2 * window)
      return std::nullopt;
    c = f.c;
  }
  return c;
}

// Share of the rays in view whose outermost edge within 1 px of c lies within 0.5 px of it.
double agreement(const cv::Mat& smooth, const cv::Mat& valid8, const BallInImage& c, int rays, double noise) {
  int agree = 0, in_view = 0;
  for (int k = 0; k < rays; ++k) in_view += ray_in_view(smooth, valid8, c, 1.0, k, rays);
  for (const Weighted& p : pick_edges(ray_edges(smooth, valid8, c, 1.0, rays), c, false, noise))
    agree += std::abs(residual(p.e, c)) < 0.5;
  return in_view ? double(agree) / in_view : 0;
}

// An enclosing hypothesis must agree along this share of the rays, half the rim: random
// circles through texture agree along 0.2-0.35, through the night renders' noise up to
// 0.49, the kartik photos' blurred rims 0.2-0.35.
constexpr double kMinArc = 0.5;

// Whether circle `outer` encloses `inner` with at least `margin` px to spare everywhere.
bool encloses(const BallInImage& outer, const BallInImage& inner, double margin) {
  return outer.radius_px - inner.radius_px - std::hypot(outer.cx - inner.cx, outer.cy - inner.cy) >= margin;
}

// The wide pass: per ray the strongest edge within 4 px + 2 % of R of the start, and
// apart the outermost that counts (a dark rim's silhouette further out than the stronger
// border of its reflection, beyond the narrowing windows' reach), a circle fitted to all
// of them and to each half of the rim (eight half-circles 45 deg apart), each narrowed.
// Where part of the rim has no silhouette (dark against dark) the edges there are something
// else, consistently (the inner border of a dark reflection): half the rays, too
// many for the biweights alone. Of the hypotheses agreeing along kMinArc of the rim, those
// enclosed by another are dropped: the silhouette is the ball's outer boundary, and a
// circle inside it that agrees along an arc is a border in the reflection (a dark object
// reflected at the rim agrees along the whole dark arc, the ball's interior along some
// more, more than the true rim, which agrees only where it has contrast). The one left
// agreeing with the most rays wins.
std::optional<BallInImage> coarse_rim(const cv::Mat& smooth, const cv::Mat& valid8, const BallInImage& start,
                                      int rays, double noise, double* best_agreement, bool* enclosed_dropped) {
  const RayEdges wide = ray_edges(smooth, valid8, start, 4 + 0.02 * start.radius_px, rays);
  std::vector<std::pair<BallInImage, double>> hyps;  // narrowed circle, agreement
  for (const bool strongest : {true, false}) {
    const auto pts = pick_edges(wide, start, strongest, noise);
    if (pts.size() < 12) continue;
    for (int h = -1; h < 8; ++h) {
      std::vector<Weighted> sub;
      for (const Weighted& p : pts) {
        const double a = std::atan2(p.e.y - start.cy, p.e.x - start.cx) - h * M_PI / 4;
        if (h < 0 || std::cos(a) > 0) sub.push_back(p);
      }
      if (sub.size() < 12) continue;
      const FitResult f = robust_circle(sub, start);
      if (f.inliers == 0 || !(f.c.radius_px > 0)) continue;
      const auto c = narrow(smooth, valid8, f.c, rays, noise);
      if (c) hyps.push_back({*c, agreement(smooth, valid8, *c, rays, noise)});
    }
  }
  std::optional<BallInImage> best;
  *best_agreement = -1;
  *enclosed_dropped = false;
  for (const auto& [c, ag] : hyps) {
    bool enclosed = false;
    for (const auto& [o, og] : hyps) enclosed = enclosed || (og >= kMinArc && encloses(o, c, 1.0));
    *enclosed_dropped = *enclosed_dropped || enclosed;
    if (!enclosed && ag > *best_agreement) *best_agreement = ag, best = c;
  }
  return best;
}

}  // namespace

RimFit fit_rim(const cv::Mat& smooth, const cv::Mat& linear, const cv::Mat& valid8, const BallInImage& start, int rays,
              double edge_noise) {
  RimFit out;
  double ag = 0;
  bool enclosed_dropped = false;
  const auto coarse = coarse_rim(smooth, valid8, start, rays, edge_noise, &ag, &enclosed_dropped);
  if (!coarse) return out;
  BallInImage c = *coarse;
  FitResult f;
  for (int pass = 0; pass < 3; ++pass) {
    const auto pts = area_edges(linear, valid8, c, rays, edge_noise);
    if (pts.size() < 12) break;
    const FitResult g = robust_circle(pts, c);
    if (g.inliers == 0 || std::hypot(g.c.cx - c.cx, g.c.cy - c.cy) > 1 || std::abs(g.c.radius_px - c.radius_px) > 1) break;
    f = g, c = g.c;
  }
  if (f.inliers == 0) return out;
  // Neighbouring rays closer than ~2 px see the same pixels.
  const double spacing = 2 * M_PI * c.radius_px / rays, inflate = std::max(1.0, 2.0 / spacing);
  cv::Vec2d ev;
  cv::eigen(cv::Mat(cv::Matx22d(f.cov(0, 0), f.cov(0, 1), f.cov(1, 0), f.cov(1, 1))), ev);
  out.ball = c;
  out.sigma_centre_px = out.noise_sigma_centre_px = std::sqrt(std::max(0.0, ev[0]) * inflate);
  out.sigma_radius_px = out.noise_sigma_radius_px = std::sqrt(std::max(0.0, f.cov(2, 2)) * inflate);
  out.rms_px = f.rms;
  out.inliers = f.inliers;
  out.agreement = ag;
  out.inner_rim_dropped = enclosed_dropped;
  out.ok = true;
  return out;
}

namespace {

// The circle's spread over the rim's sectors: the delete-a-sector jackknife over eight
// sectors of 45 deg (centre: the larger axis of its covariance; radius). Neighbouring arcs
// see neighbouring directions of the same scene, so their edges' errors are correlated
// along the rim (a stretch of it reflecting the border of a dark object sits off together),
// which the fit's covariance, built as if each arc's error were independent, does not see;
// leaving out a sector at a time does. {0, 0} when a sector's refit fails.
std::pair<double, double> sector_jackknife(const std::vector<Weighted>& pts, const BallInImage& c) {
  constexpr int kSectors = 8;
  std::vector<BallInImage> fits;
  for (int s = 0; s < kSectors; ++s) {
    std::vector<Weighted> sub;
    for (const Weighted& p : pts) {
      double a = std::atan2(p.e.y - c.cy, p.e.x - c.cx);
      if (a < 0) a += 2 * M_PI;
      if (std::min(kSectors - 1, int(a / (2 * M_PI / kSectors))) != s) sub.push_back(p);
    }
    if (sub.size() < 12) return {0.0, 0.0};
    const FitResult f = robust_circle(sub, c);
    if (f.inliers == 0) return {0.0, 0.0};
    fits.push_back(f.c);
  }
  double mx = 0, my = 0, mr = 0;
  for (const BallInImage& b : fits) mx += b.cx / kSectors, my += b.cy / kSectors, mr += b.radius_px / kSectors;
  cv::Matx22d cov;
  double vr = 0;
  const double k = double(kSectors - 1) / kSectors;
  for (const BallInImage& b : fits) {
    const cv::Vec2d d(b.cx - mx, b.cy - my);
    cov += k * d * d.t();
    vr += k * (b.radius_px - mr) * (b.radius_px - mr);
  }
  cv::Vec2d ev;
  cv::eigen(cv::Mat(cov), ev);
  return {std::sqrt(std::max(0.0, ev[0])), std::sqrt(vr)};
}

// The circle's dependence on which half of the rim it trusts, beyond noise: refitted on
// each half (eight halves, 45 deg apart), the RMS over the halves of the centre's and the
// radius's differences from the fit to all of `pts`, less what noise alone gives them (for
// nested least-squares fits the difference has the variance of the half's fit less the
// whole's: a half-circle pins its centre poorly, so noise alone moves it several times the
// whole's sigma), both covariances at the whole fit's residual scale. Where part of the rim
// has no contrast at the silhouette, its arcs hold the strongest step within reach instead
// (the inner border of a band of the reflection that matches the background, or an edge of
// the background beyond it), coherently along that stretch; the circle is then a compromise
// that moves whole, which leaving out one 45 deg sector does not show. {0, 0} when a refit
// fails.
std::pair<double, double> half_rim_spread(const std::vector<Weighted>& pts, const BallInImage& c) {
  constexpr int kHalves = 8;
  const FitResult all = robust_circle(pts, c);
  if (all.inliers == 0 || !(all.rms > 0)) return {0.0, 0.0};
  double var_c = 0, var_r = 0;
  for (int h = 0; h < kHalves; ++h) {
    std::vector<Weighted> sub;
    for (const Weighted& p : pts)
      if (std::cos(std::atan2(p.e.y - c.cy, p.e.x - c.cx) - h * 2 * M_PI / kHalves) > 0) sub.push_back(p);
    if (sub.size() < 12) return {0.0, 0.0};
    const FitResult f = robust_circle(sub, all.c);
    if (f.inliers == 0 || !(f.rms > 0)) return {0.0, 0.0};
    const double scale = (all.rms * all.rms) / (f.rms * f.rms);
    const double noise_c = scale * (f.cov(0, 0) + f.cov(1, 1)) - (all.cov(0, 0) + all.cov(1, 1));
    const double noise_r = scale * f.cov(2, 2) - all.cov(2, 2);
    var_c += std::max(0.0, std::pow(f.c.cx - all.c.cx, 2) + std::pow(f.c.cy - all.c.cy, 2) - std::max(0.0, noise_c)) / kHalves;
    var_r += std::max(0.0, std::pow(f.c.radius_px - all.c.radius_px, 2) - std::max(0.0, noise_r)) / kHalves;
  }
  return {std::sqrt(var_c), std::sqrt(var_r)};
}

// The silhouette is the ball's outer boundary: an arc whose edge lies more than the
// support's 0.5 px inside the circle holds a border in the reflection (the inner border of
// a band that matches the background, the ball's own texture), not the silhouette, while
// an edge outside it can only be an edge of the background, which the biweights handle.
// Those arcs are dropped and the circle refitted on the rest until no more drop out (at
// most 8 rounds). The Tukey scale comes from the residuals' MAD, which on a rim split into
// two groups spans both and averages them; the trimmed fit keeps to the outer one. The
// fit `f` unchanged when the trim would move it by a pass's 1 px or fewer than 12 arcs are left.
FitResult trim_inner_edges(const std::vector<Weighted>& pts, const FitResult& f) {
  FitResult out = f;
  for (int round = 0; round < 8; ++round) {
    std::vector<Weighted> kept;
    for (const Weighted& p : pts)
      if (residual(p.e, out.c) >= -0.5) kept.push_back(p);
    if (kept.size() < 12) return f;
    const FitResult g = robust_circle(kept, out.c);
    if (g.inliers == 0) return f;
    const double move = std::hypot(g.c.cx - out.c.cx, g.c.cy - out.c.cy) + std::abs(g.c.radius_px - out.c.radius_px);
    out = g;
    if (move < 0.01) break;
  }
  if (std::hypot(out.c.cx - f.c.cx, out.c.cy - f.c.cy) > 1 || std::abs(out.c.radius_px - f.c.radius_px) > 1) return f;
  return out;
}

// The wide first pass (refine_rim_by_coverage): the search reach and both pixel bands grow
// by this, so that the edge search covers 2 px either side of the rim fit's circle.
constexpr double kWideStartPx = 1.25;

}  // namespace

RimFit refine_rim_by_coverage(const cv::Mat& linear, const cv::Mat& valid8, const RimFit& rim, double edge_noise) {
  if (!rim.ok) return rim;
  const BallInImage& c = rim.ball;
  // The blur that explains the rim best (0, 0.5 or 1 px), compared on the same pixels, 2.5 px
  // either side: the edges then use the last 1.5 px + 2 x blur inside (CoverageEdgeOptions).
  CoverageEdgeOptions o;
  double best = std::numeric_limits<double>::infinity();
  for (const double blur : {0.0, 0.5, 1.0}) {
    CoverageEdgeOptions trial;
    trial.inner_band_px = 2.5, trial.outer_band_px = 2.5, trial.blur_px = blur;
    double ssr = 0;
    coverage_edges(linear, valid8, c, trial, &ssr);
    if (ssr < best) best = ssr, o.blur_px = blur;
  }
  // Bands of the rim's reflection up to 3 px wide outside the one-step edge: the rim fit
  // looks for edges on the image smoothed by 1 px, where a band narrower than about 3 sigma
  // merges with its stronger inner border (a dark band at the rim of a ball 60 px across is
  // 2 px wide); wider bands it resolves, its outermost edge being the silhouette.
  o.band_px = 3;
  // Two circles, each refined in up to three passes while it moves less than max_move: on
  // the arcs' one-step edges, and with the band's outer edge where an arc shows one. The
  // background's own edges near the ball show up as bands too, on arcs scattered round the
  // rim, while a band of the reflection lies along a stretch of it; so the circle more of
  // the arcs agree with (any of an arc's edges within 0.5 px, Tukey-weighted) wins, the
  // one-step circle on a tie.
  struct Refined {
    BallInImage c;
    FitResult f;
    double support = -1;
    int seen = 0;               // arcs with an edge in the last pass
    std::vector<Weighted> pts;  // the edges of the last pass
  };
  std::vector<CoverageArc> first_arcs[2];  // per start: both circles' first pass is the same
  auto refine = [&](bool use_bands, bool wide_start) {
    Refined out{rim.ball, {}, -1, 0, {}};
    // A pass may move the circle by 1 px; with bands by up to half the widest band more
    // (a band along half the rim moves it by about half its width); from the wide start by
    // kWideStartPx more.
    const double wide = wide_start ? kWideStartPx : 0.0;
    const double max_move = (use_bands ? 1 + 0.5 * o.band_px : 1.0) + wide;
    for (int pass = 0; pass < 3 + (wide_start ? 1 : 0); ++pass) {
      CoverageEdgeOptions po = o;
      if (pass == 0 && wide_start) po.reach_px += wide, po.inner_band_px += wide, po.outer_band_px += wide;
      auto& first = first_arcs[wide_start];
      if (pass == 0 && first.empty()) first = coverage_arcs(linear, valid8, out.c, po);
      const std::vector<CoverageArc> arcs = pass == 0 ? first : coverage_arcs(linear, valid8, out.c, po);
      std::vector<RimEdge> edges;
      for (const CoverageArc& a : arcs)
        if (use_bands && a.band.strength >= 0) edges.push_back(a.band);
        else if (a.step.strength >= 0) edges.push_back(a.step);
      if (edges.size() < 12) break;
      std::vector<double> s;
      for (const RimEdge& e : edges) s.push_back(e.strength);
      const double med = median_of(s);
      std::vector<Weighted> pts;
      // Each edge rests on an arc's ~40 pixels, yet as for area_edges the contrast of its two
      // sides is weighed against 4 x the smoothed image's noise (a conservative floor).
      for (const RimEdge& e : edges) pts.push_back({e, edge_weight(e.strength, e.rel, med, 4 * edge_noise)});
      const FitResult g = robust_circle(pts, out.c);
      if (g.inliers == 0 || std::hypot(g.c.cx - out.c.cx, g.c.cy - out.c.cy) > max_move ||
          std::abs(g.c.radius_px - out.c.radius_px) > max_move)
        break;
      const bool settled =
          std::hypot(g.c.cx - out.c.cx, g.c.cy - out.c.cy) < 0.01 && std::abs(g.c.radius_px - out.c.radius_px) < 0.01;
      out.f = g, out.c = g.c, out.support = 0, out.seen = 0, out.pts = pts;
      for (const CoverageArc& a : arcs) {
        out.seen += a.step.strength >= 0 || a.band.strength >= 0;
        double w = 0;
        for (const RimEdge* e : {&a.step, &a.band}) {
          const double u = residual(*e, g.c) / 0.5;
          if (e->strength >= 0 && std::abs(u) < 1) w = std::max(w, (1 - u * u) * (1 - u * u));
        }
        out.support += w;
      }
      if (settled) break;
    }
    return out;
  };
  // From one start, the winner of the two circles and the other one. The silhouette is the
  // ball's outer boundary: a banded circle that encloses the one-step circle by half a pixel
  // all round and agrees with half of its arcs wins even with less support (the one-step
  // circle sits on the inner border of a band along part of the rim, the banded one on its
  // outer edge where the band test passed: sunset, dark, R 60).
  auto choose = [&](bool wide_start) {
    Refined winner = refine(false, wide_start), other;
    if (o.band_px > 0) {
      other = refine(true, wide_start);
      const double margin = other.c.radius_px - winner.c.radius_px - std::hypot(other.c.cx - winner.c.cx, other.c.cy - winner.c.cy);
      const bool encloses = other.f.inliers > 0 && margin >= 0.5 && other.support >= 0.5 * other.seen;
      if (other.support > winner.support || encloses) std::swap(winner, other);
    }
    return std::pair<Refined, Refined>{winner, other};
  };
  auto [best_fit, other] = choose(false);
  // A winner that agrees with fewer than half of its arcs may be trapped: the rim fit's
  // circle can be off by more than the edge search's reach (0.75 px) where its outermost
  // edges were a background edge just outside the silhouette on one side and the inner
  // border of a band on the other (studio, dark, R 60: 2.2 px). The arcs around such a
  // circle find whatever lies within reach and hold it there. So the refinement is started
  // once more with a wide first pass (reach and pixel bands 1.25 px wider, then the narrow
  // passes), and its winner replaces the first where the arcs agree with it by a clear
  // margin: 2 sqrt(n) arcs, four standard deviations of the number of n arcs agreeing by
  // chance with probability one half. The wide pass's deeper pixels bias it by tenths of a
  // pixel (their own structure), so it does not replace a circle that holds.
  if (best_fit.support < 0.5 * best_fit.seen) {
    auto [wide_best, wide_other] = choose(true);
    if (wide_best.support - best_fit.support > 2 * std::sqrt(double(std::max(wide_best.seen, best_fit.seen))))
      best_fit = wide_best, other = wide_other;
  }
  if (best_fit.f.inliers == 0) return rim;
  const FitResult f = trim_inner_edges(best_fit.pts, best_fit.f);
  const BallInImage fitted = f.c;
  RimFit out = rim;
  cv::Vec2d ev;
  cv::eigen(cv::Mat(cv::Matx22d(f.cov(0, 0), f.cov(0, 1), f.cov(1, 0), f.cov(1, 1))), ev);
  out.ball = fitted;
  out.noise_sigma_centre_px = std::sqrt(std::max(0.0, ev[0]));
  out.noise_sigma_radius_px = std::sqrt(std::max(0.0, f.cov(2, 2)));
  // The sigmas cover more than the noise: the sectors' spread (the jackknife, or the halves'
  // spread, where it exceeds the covariance) and the choice between the two circles (their
  // difference). On all the edges, the trimmed ones included: they are the evidence that
  // the rim allows another circle.
  const auto [jack_c, jack_r] = sector_jackknife(best_fit.pts, fitted);
  const auto [half_c, half_r] = half_rim_spread(best_fit.pts, fitted);
  double model_c = 0, model_r = 0;
  if (other.f.inliers > 0) {
    model_c = std::hypot(other.c.cx - fitted.cx, other.c.cy - fitted.cy);
    model_r = std::abs(other.c.radius_px - fitted.radius_px);
  }
  out.sigma_centre_px = std::hypot(std::max({out.noise_sigma_centre_px, jack_c, half_c}), model_c);
  out.sigma_radius_px = std::hypot(std::max({out.noise_sigma_radius_px, jack_r, half_r}), model_r);
  out.rms_px = f.rms;
  out.inliers = f.inliers;
  return out;
}

double edge_noise_level(const cv::Mat& smooth, const cv::Mat& valid8) {
  std::vector<float> d;
  d.reserve(size_t(smooth.rows) * smooth.cols);
  for (int y = 0; y < smooth.rows; ++y) {
    const cv::Vec3f* row = smooth.ptr<cv::Vec3f>(y);
    const uint8_t* ok = valid8.empty() ? nullptr : valid8.ptr<uint8_t>(y);
    for (int x = 0; x + 1 < smooth.cols; ++x) {
      if (ok && !(ok[x] && ok[x + 1])) continue;
      const cv::Vec3f g = row[x + 1] - row[x];
      d.push_back(std::abs(g[0]) + std::abs(g[1]) + std::abs(g[2]));
    }
  }
  if (d.empty()) return 0;
  std::nth_element(d.begin(), d.begin() + d.size() / 20, d.end());
  return 7.0 * d[d.size() / 20];
}

}  // namespace lp
