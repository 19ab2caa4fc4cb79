#include "probe/ball_rim_coverage.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>

namespace lp {

namespace {

// Points per pixel edge for its area integral: 64 distances to the centre, so that moving
// the edge by 0.02 px changes the coverage of some of an arc's pixels.
constexpr int kSub = 8, kPoints = kSub * kSub;
// Unknowns per channel: ball b0, b1 d, b2 t; background g0, g1 s, g2 t.
constexpr int kTerms = 6;
// A band narrower than this is a shifted edge, which the one-step search covers.
constexpr double kMinBandPx = 0.5;

struct ArcPixel {
  cv::Vec3f value;
  float t;                             // px along the rim from the arc's middle
  // The area points' distances to the circle's centre minus its radius, ascending, and
  // their running sums: a pixel's terms for any edge then take one binary search instead
  // of a pass over its points (the edge search evaluates each pixel at some 40 edges).
  std::array<float, kPoints> dist;
  std::array<float, kPoints + 1> prefix;
  float centre;  // the pixel centre's distance to the circle's centre minus its radius
};

using Features = std::array<double, kTerms>;

// The area points below edge `e` (relative to the radius): how many, and the sums of
// their depths (e - dist) and of the others' distances outside (dist - e).
struct Split {
  int in;
  double depth, outside;
};

Split split(const ArcPixel& p, double e) {
  const int k = int(std::lower_bound(p.dist.begin(), p.dist.end(), float(e)) - p.dist.begin());
  return {k, k * e - p.prefix[k], (p.prefix[kPoints] - p.prefix[k]) - (kPoints - k) * e};
}

// The pixel's model terms for an edge at `edge` (relative to the radius): each a mean
// over its area points.
Features features(const ArcPixel& p, double edge) {
  const Split s = split(p, edge);
  Features f{double(s.in), s.depth, 0, double(kPoints - s.in), s.outside, 0};
  for (double& v : f) v /= kPoints;
  f[2] = f[0] * p.t, f[5] = f[3] * p.t;
  return f;
}

template <int N>
struct ArcFitN {
  double ssr = std::numeric_limits<double>::infinity();
  cv::Matx<double, N, 3> beta;
};
using ArcFit = ArcFitN<kTerms>;

// Least squares of the arc's pixels on a model linear in `feat(pixel)` (N terms), all channels.
template <int N, class Feat>
ArcFitN<N> fit_terms(const std::vector<ArcPixel>& px, Feat feat) {
  cv::Matx<double, N, N> n;
  cv::Matx<double, N, 3> rhs;
  // One buffer per thread: the edge searches call this some 40 times per arc.
  thread_local std::vector<std::array<double, N>> fs;
  fs.resize(px.size());
  for (size_t i = 0; i < px.size(); ++i) {
    fs[i] = feat(px[i]);
    for (int a = 0; a < N; ++a) {
      for (int b = a; b < N; ++b) n(a, b) += fs[i][a] * fs[i][b];
      for (int ch = 0; ch < 3; ++ch) rhs(a, ch) += fs[i][a] * px[i].value[ch];
    }
  }
  for (int a = 0; a < N; ++a)  // the same products, so the same sums
    for (int b = 0; b < a; ++b) n(a, b) = n(b, a);
  // A trace-relative ridge keeps the solve defined where a term has no support (an edge
  // search that puts every pixel on one side).
  double tr = 0;
  for (int a = 0; a < N; ++a) tr += n(a, a);
  for (int a = 0; a < N; ++a) n(a, a) += 1e-9 * tr + 1e-300;
  ArcFitN<N> out;
  if (!cv::solve(n, rhs, out.beta, cv::DECOMP_CHOLESKY)) return out;
  double ssr = 0;
  for (size_t i = 0; i < px.size(); ++i)
    for (int ch = 0; ch < 3; ++ch) {
      double m = 0;
      for (int a = 0; a < N; ++a) m += fs[i][a] * out.beta(a, ch);
      const double r = px[i].value[ch] - m;
      ssr += r * r;
    }
  out.ssr = ssr;
  return out;
}

// The one-step model with the edge at `edge` (relative to the radius).
ArcFit fit_arc(const std::vector<ArcPixel>& px, double edge) {
  return fit_terms<kTerms>(px, [edge](const ArcPixel& p) { return features(p, edge); });
}

// Outside the one-step edge `inner`: a band of the ball's rim (c0 + c1 t) up to the
// silhouette `outer`, the background (g0 + g1 s + g2 t, s from `outer`) beyond; with
// `outer` = `inner`, the background alone.
constexpr int kBandTerms = 5;
ArcFitN<kBandTerms> fit_band(const std::vector<ArcPixel>& px, double inner, double outer) {
  return fit_terms<kBandTerms>(px, [inner, outer](const ArcPixel& p) {
    const Split a = split(p, inner), b = split(p, outer);
    const double mid = b.in - a.in, out = kPoints - b.in;
    std::array<double, kBandTerms> f{mid, mid * p.t, out, b.outside, out * p.t};
    for (double& v : f) v /= kPoints;
    return f;
  });
}

// Where the ball's rim reflects a band whose inner border is the arc's one-step edge
// `inner` (its contrast to the ball won the one-step search): the silhouette as the band's
// outer edge. Only the pixels wholly outside `inner` take part, so that the ball's bright
// and textured reflection neither pulls the band's edge nor drowns a dim band against a dim
// background in its residual. The band counts when it beats the background alone by kBandF
// (an F statistic: the band's two terms per channel and its edge); nullopt when it does
// not. `in`/`out`: the band's and the background's values half a pixel either side of it.
struct BandEdge {
  double edge;
  cv::Vec3d in, out;
};
constexpr double kBandF = 10;

std::optional<BandEdge> outer_band_edge(const std::vector<ArcPixel>& wide, double inner, const CoverageEdgeOptions& o) {
  // A pixel's square (blurred) lies outside `inner` when its centre is 0.71 px (half the
  // diagonal) + 2 blur beyond it.
  std::vector<ArcPixel> px;
  for (const ArcPixel& p : wide)
    if (p.centre >= inner + 0.71 + 2 * o.blur_px && p.centre <= inner + o.band_px + o.outer_band_px) px.push_back(p);
  if (px.size() < 4 * kBandTerms) return std::nullopt;
  const double none = fit_band(px, inner, inner).ssr;
  const double coarse = 0.1, fine = 0.02, lo = inner + kMinBandPx;
  const int nc = int(std::floor((o.band_px - kMinBandPx) / coarse));
  if (nc < 2) return std::nullopt;
  int best = 0;
  double best_ssr = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= nc; ++i) {
    const double s = fit_band(px, inner, lo + i * coarse).ssr;
    if (s < best_ssr) best_ssr = s, best = i;
  }
  if (best == 0 || best == nc) return std::nullopt;  // no minimum inside the range
  std::array<double, 11> ssr;
  for (int i = 0; i < 11; ++i) ssr[i] = fit_band(px, inner, lo + best * coarse + (i - 5) * fine).ssr;
  const int m = int(std::min_element(ssr.begin() + 1, ssr.end() - 1) - ssr.begin());
  const double den = ssr[m - 1] - 2 * ssr[m] + ssr[m + 1];
  const double off = den > 0 ? std::clamp(0.5 * (ssr[m - 1] - ssr[m + 1]) / den, -0.5, 0.5) : 0.0;
  const double edge = lo + best * coarse + (m - 5 + off) * fine;
  const auto f = fit_band(px, inner, edge);
  const double dof = 3.0 * px.size() - 3 * kBandTerms - 1;
  if (!std::isfinite(f.ssr) || !(dof > 0)) return std::nullopt;
  const double stat = ((none - f.ssr) / 7) / (std::max(f.ssr, 1e-300) / dof);
  if (!(stat > kBandF)) return std::nullopt;
  BandEdge out{edge, {}, {}};
  for (int ch = 0; ch < 3; ++ch) out.in[ch] = f.beta(0, ch), out.out[ch] = f.beta(2, ch) + f.beta(3, ch) * 0.5;
  return out;
}

}  // namespace

std::vector<CoverageArc> coverage_arcs(const cv::Mat& linear, const cv::Mat& valid8, const BallInImage& c,
                                       const CoverageEdgeOptions& o, double* residual) {
  const double r = c.radius_px, inner_band = o.inner_band_px + 2 * o.blur_px;
  const double band = std::max(inner_band, o.outer_band_px);
  // The aperture's blur: each area point moved by a fixed standard normal offset (Box-Muller
  // on stratified uniforms, paired with the grid in a scrambled order), times blur_px.
  std::array<std::array<double, 2>, kPoints> blur;
  for (int q = 0; q < kPoints; ++q) {
    const double u1 = (q + 0.5) / kPoints, u2 = std::fmod(q * 0.6180339887, 1.0), m = std::sqrt(-2 * std::log(u1));
    blur[(q * 37) % kPoints] = {m * std::cos(2 * M_PI * u2), m * std::sin(2 * M_PI * u2)};
  }
  const int arcs = std::max(16, int(std::lround(2 * M_PI * r / o.arc_px)));
  const double arc_angle = 2 * M_PI / arcs;
  // The band search's pixels: from the one-step search's innermost edge minus the inner band
  // to its outermost plus the widest band and the outer band.
  const bool banded = o.band_px > kMinBandPx;
  const double wide_in = banded ? o.reach_px + inner_band : inner_band;
  const double wide_out = banded ? o.reach_px + o.band_px + o.outer_band_px : o.outer_band_px;
  const double extent = std::max({band, wide_in, wide_out});
  std::vector<std::vector<ArcPixel>> px(arcs), wide(arcs);
  std::vector<char> usable(arcs, 1), usable_wide(arcs, banded ? 1 : 0);
  // Arcs reaching the image border are left out whole: a partial arc loses the phases
  // that pin its profile down.
  for (int k = 0; k < arcs; ++k)
    for (const double a : {k * arc_angle, (k + 0.5) * arc_angle, (k + 1) * arc_angle}) {
      auto outside = [&](double rr) {
        const double x = c.cx + rr * std::cos(a), y = c.cy + rr * std::sin(a);
        return x < 1 || y < 1 || x > linear.cols - 1 || y > linear.rows - 1;
      };
      if (outside(r - band - 1) || outside(r + band + 1)) usable[k] = 0;
      if (outside(r - wide_in - 1) || outside(r + wide_out + 1)) usable_wide[k] = 0;
    }
  const int x0 = std::max(0, int(std::floor(c.cx - r - extent - 1))), x1 = std::min(linear.cols - 1, int(c.cx + r + extent + 1));
  const int y0 = std::max(0, int(std::floor(c.cy - r - extent - 1))), y1 = std::min(linear.rows - 1, int(c.cy + r + extent + 1));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double dx = x + 0.5 - c.cx, dy = y + 0.5 - c.cy, dc = std::hypot(dx, dy);
      const bool narrow = !(dc - r > o.outer_band_px || r - dc > inner_band);
      const bool in_wide = banded && !(dc - r > wide_out || r - dc > wide_in);
      if (!narrow && !in_wide) continue;
      double a = std::atan2(dy, dx);
      if (a < 0) a += 2 * M_PI;
      const int k = std::min(arcs - 1, int(a / arc_angle));
      if (!usable[k] && !usable_wide[k]) continue;
      if (!valid8.empty() && !valid8.at<uint8_t>(y, x)) {
        if (narrow) usable[k] = 0;
        usable_wide[k] = 0;
        continue;
      }
      ArcPixel p;
      p.value = linear.at<cv::Vec3f>(y, x);
      p.t = float(r * (a - (k + 0.5) * arc_angle));
      p.centre = float(dc - r);
      for (int j = 0; j < kSub; ++j)
        for (int i = 0; i < kSub; ++i) {
          const auto& n = blur[j * kSub + i];
          // sqrt, not hypot (a fifth of this function's time): no overflow at image scales.
          const double qx = x + (i + 0.5) / kSub + o.blur_px * n[0] - c.cx, qy = y + (j + 0.5) / kSub + o.blur_px * n[1] - c.cy;
          p.dist[j * kSub + i] = float(std::sqrt(qx * qx + qy * qy) - r);
        }
      std::sort(p.dist.begin(), p.dist.end());
      p.prefix[0] = 0;
      for (int q = 0; q < kPoints; ++q) p.prefix[q + 1] = p.prefix[q] + p.dist[q];
      if (narrow && usable[k]) px[k].push_back(p);
      if (in_wide && usable_wide[k]) wide[k].push_back(p);
    }

  std::vector<CoverageArc> edges(arcs);
  std::vector<double> arc_ssr(arcs, 0.0);
  tbb::parallel_for(0, arcs, [&](int k) {
    if (!usable[k] || px[k].size() < 2 * kTerms) return;
    // Coarse steps of 0.05 px over the reach, then 0.01 px around the best, a parabola last.
    const double coarse = 0.05, fine = 0.01;
    const int nc = int(std::lround(o.reach_px / coarse));
    int best = 0;
    double best_ssr = std::numeric_limits<double>::infinity();
    for (int i = -nc; i <= nc; ++i) {
      const double s = fit_arc(px[k], i * coarse).ssr;
      if (s < best_ssr) best_ssr = s, best = i;
    }
    arc_ssr[k] = best_ssr;
    const double a = (k + 0.5) * arc_angle;
    auto put = [&](RimEdge& e, double edge, const cv::Vec3d& in, const cv::Vec3d& out) {
      const double si = in[0] + in[1] + in[2], so = out[0] + out[1] + out[2], level = std::max(si, so);
      e = {c.cx + (r + edge) * std::cos(a), c.cy + (r + edge) * std::sin(a), cv::norm(in - out),
           level > 0 ? std::abs(si - so) / level : 0.0};
    };
    double edge = best * coarse;  // relative to r
    if (std::abs(best) != nc) {
      std::array<double, 11> ssr;
      for (int i = 0; i < 11; ++i) ssr[i] = fit_arc(px[k], best * coarse + (i - 5) * fine).ssr;
      const int m = int(std::min_element(ssr.begin() + 1, ssr.end() - 1) - ssr.begin());
      const double den = ssr[m - 1] - 2 * ssr[m] + ssr[m + 1];
      const double off = den > 0 ? std::clamp(0.5 * (ssr[m - 1] - ssr[m + 1]) / den, -0.5, 0.5) : 0.0;
      edge = best * coarse + (m - 5 + off) * fine;
    }
    // The silhouette is the ball's outer boundary: a band of the rim's reflection outside
    // the one-step edge (its strong inner border won the one-step search) puts it further out.
    if (usable_wide[k] && wide[k].size() >= 2 * kBandTerms)
      if (const auto band_edge = outer_band_edge(wide[k], edge, o))
        put(edges[k].band, band_edge->edge, band_edge->in, band_edge->out);
    if (std::abs(best) == nc) return;  // no minimum within reach
    const ArcFit f = fit_arc(px[k], edge);
    if (!std::isfinite(f.ssr)) return;
    cv::Vec3d in, out;
    for (int ch = 0; ch < 3; ++ch) {
      in[ch] = f.beta(0, ch) + f.beta(1, ch) * 0.5;
      out[ch] = f.beta(3, ch) + f.beta(4, ch) * 0.5;
    }
    put(edges[k].step, edge, in, out);
  });
  if (residual) {
    *residual = 0;
    for (const double v : arc_ssr) *residual += std::isfinite(v) ? v : 0.0;
  }
  return edges;
}

std::vector<RimEdge> coverage_edges(const cv::Mat& linear, const cv::Mat& valid8, const BallInImage& c,
                                    const CoverageEdgeOptions& o, double* residual) {
  std::vector<RimEdge> found;
  for (const CoverageArc& a : coverage_arcs(linear, valid8, c, o, residual))
    if (a.step.strength >= 0) found.push_back(a.step);
  return found;
}

}  // namespace lp
