#include "probe/ball_rim_coverage.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace lp {

namespace {

// Points per pixel edge for its area integral: 64 distances to the centre, so that moving
// the edge by 0.02 px changes the coverage of some of an arc's pixels.
constexpr int kSub = 8, kPoints = kSub * kSub;
// Unknowns per channel: ball b0, b1 d, b2 t; background g0, g1 s, g2 t.
constexpr int kTerms = 6;

struct ArcPixel {
  cv::Vec3f value;
  float t;                             // px along the rim from the arc's middle
  std::array<float, kPoints> dist;     // the area points' distances to the circle's centre
};

using Features = std::array<double, kTerms>;

// The pixel's model terms for an edge at radius `edge`: each a mean over its area points.
Features features(const ArcPixel& p, double edge) {
  Features f{};
  for (const float dist : p.dist) {
    const double d = edge - dist;
    if (d > 0) {
      f[0] += 1, f[1] += d;
    } else {
      f[3] += 1, f[4] -= d;
    }
  }
  for (double& v : f) v /= kPoints;
  f[2] = f[0] * p.t, f[5] = f[3] * p.t;
  return f;
}

struct ArcFit {
  double ssr = std::numeric_limits<double>::infinity();
  cv::Matx<double, kTerms, 3> beta;
};

// Least squares of the arc's pixels on the model with the edge at `edge`, all channels.
ArcFit fit_arc(const std::vector<ArcPixel>& px, double edge) {
  cv::Matx<double, kTerms, kTerms> n;
  cv::Matx<double, kTerms, 3> rhs;
  std::vector<Features> fs(px.size());
  for (size_t i = 0; i < px.size(); ++i) {
    fs[i] = features(px[i], edge);
    for (int a = 0; a < kTerms; ++a) {
      for (int b = 0; b < kTerms; ++b) n(a, b) += fs[i][a] * fs[i][b];
      for (int ch = 0; ch < 3; ++ch) rhs(a, ch) += fs[i][a] * px[i].value[ch];
    }
  }
  // A trace-relative ridge keeps the solve defined where a term has no support (an edge
  // search that puts every pixel on one side).
  double tr = 0;
  for (int a = 0; a < kTerms; ++a) tr += n(a, a);
  for (int a = 0; a < kTerms; ++a) n(a, a) += 1e-9 * tr + 1e-300;
  ArcFit out;
  if (!cv::solve(n, rhs, out.beta, cv::DECOMP_CHOLESKY)) return out;
  double ssr = 0;
  for (size_t i = 0; i < px.size(); ++i)
    for (int ch = 0; ch < 3; ++ch) {
      double m = 0;
      for (int a = 0; a < kTerms; ++a) m += fs[i][a] * out.beta(a, ch);
      const double r = px[i].value[ch] - m;
      ssr += r * r;
    }
  out.ssr = ssr;
  return out;
}

}  // namespace

std::vector<RimEdge> coverage_edges(const cv::Mat& linear, const cv::Mat& valid8, const BallInImage& c,
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
  std::vector<std::vector<ArcPixel>> px(arcs);
  std::vector<char> usable(arcs, 1);
  // Arcs reaching the image border are left out whole: a partial arc loses the phases
  // that pin its profile down.
  for (int k = 0; k < arcs; ++k)
    for (const double a : {k * arc_angle, (k + 0.5) * arc_angle, (k + 1) * arc_angle})
      for (const double rr : {r - band - 1, r + band + 1}) {
        const double x = c.cx + rr * std::cos(a), y = c.cy + rr * std::sin(a);
        if (x < 1 || y < 1 || x > linear.cols - 1 || y > linear.rows - 1) usable[k] = 0;
      }
  const int x0 = std::max(0, int(std::floor(c.cx - r - band - 1))), x1 = std::min(linear.cols - 1, int(c.cx + r + band + 1));
  const int y0 = std::max(0, int(std::floor(c.cy - r - band - 1))), y1 = std::min(linear.rows - 1, int(c.cy + r + band + 1));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const double dx = x + 0.5 - c.cx, dy = y + 0.5 - c.cy, dc = std::hypot(dx, dy);
      if (dc - r > o.outer_band_px || r - dc > inner_band) continue;
      double a = std::atan2(dy, dx);
      if (a < 0) a += 2 * M_PI;
      const int k = std::min(arcs - 1, int(a / arc_angle));
      if (!usable[k]) continue;
      if (!valid8.empty() && !valid8.at<uint8_t>(y, x)) {
        usable[k] = 0;
        continue;
      }
      ArcPixel p;
      p.value = linear.at<cv::Vec3f>(y, x);
      p.t = float(r * (a - (k + 0.5) * arc_angle));
      for (int j = 0; j < kSub; ++j)
        for (int i = 0; i < kSub; ++i) {
          const auto& n = blur[j * kSub + i];
          p.dist[j * kSub + i] = float(std::hypot(x + (i + 0.5) / kSub + o.blur_px * n[0] - c.cx,
                                                  y + (j + 0.5) / kSub + o.blur_px * n[1] - c.cy));
        }
      px[k].push_back(p);
    }

  std::vector<RimEdge> edges(arcs, RimEdge{0, 0, -1});
  std::vector<double> arc_ssr(arcs, 0.0);
  tbb::parallel_for(0, arcs, [&](int k) {
    if (!usable[k] || px[k].size() < 2 * kTerms) return;
    // Coarse steps of 0.05 px over the reach, then 0.01 px around the best, a parabola last.
    const double coarse = 0.05, fine = 0.01;
    const int nc = int(std::lround(o.reach_px / coarse));
    int best = 0;
    double best_ssr = std::numeric_limits<double>::infinity();
    for (int i = -nc; i <= nc; ++i) {
      const double s = fit_arc(px[k], r + i * coarse).ssr;
      if (s < best_ssr) best_ssr = s, best = i;
    }
    arc_ssr[k] = best_ssr;
    if (std::abs(best) == nc) return;  // no minimum within reach
    std::array<double, 11> ssr;
    for (int i = 0; i < 11; ++i) ssr[i] = fit_arc(px[k], r + best * coarse + (i - 5) * fine).ssr;
    const int m = int(std::min_element(ssr.begin() + 1, ssr.end() - 1) - ssr.begin());
    const double den = ssr[m - 1] - 2 * ssr[m] + ssr[m + 1];
    const double off = den > 0 ? std::clamp(0.5 * (ssr[m - 1] - ssr[m + 1]) / den, -0.5, 0.5) : 0.0;
    const double edge = r + best * coarse + (m - 5 + off) * fine;
    const ArcFit f = fit_arc(px[k], edge);
    if (!std::isfinite(f.ssr)) return;
    cv::Vec3d in, out;
    for (int ch = 0; ch < 3; ++ch) {
      in[ch] = f.beta(0, ch) + f.beta(1, ch) * 0.5;
      out[ch] = f.beta(3, ch) + f.beta(4, ch) * 0.5;
    }
    const double si = in[0] + in[1] + in[2], so = out[0] + out[1] + out[2], level = std::max(si, so);
    const double a = (k + 0.5) * arc_angle;
    edges[k] = {c.cx + edge * std::cos(a), c.cy + edge * std::sin(a), cv::norm(in - out),
                level > 0 ? std::abs(si - so) / level : 0.0};
  });
  if (residual) {
    *residual = 0;
    for (const double v : arc_ssr) *residual += std::isfinite(v) ? v : 0.0;
  }
  std::vector<RimEdge> found;
  for (const RimEdge& e : edges)
    if (e.strength >= 0) found.push_back(e);
  return found;
}

}  // namespace lp
