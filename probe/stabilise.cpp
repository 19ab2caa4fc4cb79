#include "probe/stabilise.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "core/envmap.h"
#include "core/error.h"

namespace lp {
namespace {

double median_of(std::vector<double> v) {
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + m, v.end());
  if (v.size() % 2) return v[m];
  const double hi = v[m];
  return 0.5 * (hi + *std::max_element(v.begin(), v.begin() + m));
}

std::vector<double> smooth_component(const std::vector<double>& x, const SmoothOptions& o) {
  const int n = int(x.size());
  std::vector<double> med(n);
  const int h = o.median_window / 2;
  std::vector<double> win;
  for (int i = 0; i < n; ++i) {
    const int a = std::max(0, i - h), b = std::min(n - 1, i + h);
    win.assign(x.begin() + a, x.begin() + b + 1);
    med[i] = median_of(win);
  }
  if (!(o.gaussian_sigma > 0)) return med;
  const int rad = int(std::ceil(3 * o.gaussian_sigma));
  std::vector<double> w(rad + 1);
  for (int k = 0; k <= rad; ++k) w[k] = std::exp(-0.5 * k * k / (o.gaussian_sigma * o.gaussian_sigma));
  std::vector<double> out(n);
  for (int i = 0; i < n; ++i) {
    double s = 0, sw = 0;
    for (int j = std::max(0, i - rad); j <= std::min(n - 1, i + rad); ++j) {
      s += w[std::abs(j - i)] * med[j];
      sw += w[std::abs(j - i)];
    }
    out[i] = s / sw;  // truncated at the ends and renormalised
  }
  return out;
}

// Solve a 3x3 system (row-major) by Cramer's rule; false when singular.
bool solve3(const std::array<double, 9>& a, const std::array<double, 3>& b, std::array<double, 3>* x) {
  auto det = [](const std::array<double, 9>& m) {
    return m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) +
           m[2] * (m[3] * m[7] - m[4] * m[6]);
  };
  const double d = det(a);
  if (!(std::abs(d) > 1e-300)) return false;
  for (int c = 0; c < 3; ++c) {
    std::array<double, 9> m = a;
    for (int r = 0; r < 3; ++r) m[3 * r + c] = b[r];
    (*x)[c] = det(m) / d;
  }
  return true;
}

struct Pt {
  double x, y;
};

// Algebraic (Kasa) fit, then Gauss-Newton on the geometric distance.
bool fit_circle(const std::vector<Pt>& p, double* cx, double* cy, double* r) {
  if (p.size() < 3) return false;
  // Centre the data for conditioning.
  double mx = 0, my = 0;
  for (const Pt& q : p) {
    mx += q.x;
    my += q.y;
  }
  mx /= p.size();
  my /= p.size();
  std::array<double, 9> a{};
  std::array<double, 3> b{};
  for (const Pt& q : p) {
    const double x = q.x - mx, y = q.y - my, z = x * x + y * y;
    const double row[3] = {x, y, 1};
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) a[3 * i + j] += row[i] * row[j];
      b[i] -= row[i] * z;
    }
  }
  std::array<double, 3> s;
  if (!solve3(a, b, &s)) return false;
  double ccx = -s[0] / 2, ccy = -s[1] / 2;
  double rr2 = ccx * ccx + ccy * ccy - s[2];
  if (!(rr2 > 0)) return false;
  double rr = std::sqrt(rr2);
  for (int it = 0; it < 10; ++it) {
    std::array<double, 9> jtj{};
    std::array<double, 3> jtr{};
    for (const Pt& q : p) {
      const double dx = q.x - mx - ccx, dy = q.y - my - ccy, d = std::hypot(dx, dy);
      if (d == 0) continue;
      const double res = d - rr;
      const double j[3] = {-dx / d, -dy / d, -1};
      for (int i = 0; i < 3; ++i) {
        for (int k = 0; k < 3; ++k) jtj[3 * i + k] += j[i] * j[k];
        jtr[i] -= j[i] * res;
      }
    }
    std::array<double, 3> step;
    if (!solve3(jtj, jtr, &step)) break;
    ccx += step[0];
    ccy += step[1];
    rr += step[2];
    if (std::abs(step[0]) + std::abs(step[1]) + std::abs(step[2]) < 1e-10) break;
  }
  *cx = ccx + mx;
  *cy = ccy + my;
  *r = rr;
  return rr > 0;
}

}  // namespace

CircleTrack smooth_track(const CircleTrack& raw, const SmoothOptions& options) {
  if (raw.cx.size() != raw.cy.size() || raw.cx.size() != raw.r.size())
    throw InputError("circle track has " + std::to_string(raw.cx.size()) + " cx, " + std::to_string(raw.cy.size()) +
                     " cy and " + std::to_string(raw.r.size()) + " r values");
  if (options.median_window < 1) throw InputError("smoothing median_window must be at least 1 frame");
  if (options.gaussian_sigma < 0) throw InputError("smoothing gaussian_sigma must not be negative");
  CircleTrack out;
  if (raw.cx.empty()) return out;
  if (options.static_probe) {
    const size_t n = raw.cx.size();
    out.cx.assign(n, median_of(raw.cx));
    out.cy.assign(n, median_of(raw.cy));
    out.r.assign(n, median_of(raw.r));
    return out;
  }
  out.cx = smooth_component(raw.cx, options);
  out.cy = smooth_component(raw.cy, options);
  out.r = smooth_component(raw.r, options);
  return out;
}

double residual_jitter_px(const CircleTrack& track) {
  const size_t n = std::min(track.cx.size(), track.cy.size());
  if (n < 2) return 0;
  double s = 0;
  for (size_t i = 1; i < n; ++i) {
    const double dx = track.cx[i] - track.cx[i - 1], dy = track.cy[i] - track.cy[i - 1];
    s += dx * dx + dy * dy;
  }
  return std::sqrt(s / (2.0 * double(n - 1)));
}

ImageCircle find_image_circle(const RgbImage& image, const FindCircleOptions& options) {
  const int W = image.width, H = image.height;
  if (W < 8 || H < 8 || image.rgb.size() != size_t(W) * H * 3)
    throw InputError("find_image_circle: image is " + std::to_string(W) + "x" + std::to_string(H) +
                     ", needs RGB pixels and at least 8x8");
  if (options.rays < 8) throw InputError("find_image_circle: needs at least 8 rays");
  std::vector<float> lum(size_t(W) * H);
  for (size_t i = 0; i < lum.size(); ++i) {
    const float* p = &image.rgb[3 * i];
    lum[i] = std::isfinite(p[0] + p[1] + p[2]) ? luminance(p[0], p[1], p[2]) : 0.0f;
  }
  std::vector<float> sorted = lum;
  auto pct = [&](double q) {
    const size_t k = std::min(sorted.size() - 1, size_t(q * double(sorted.size())));
    std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
    return double(sorted[k]);
  };
  const double dark = pct(0.01), bright = pct(0.90);
  if (!(bright > dark)) throw InputError("find_image_circle: no bright disc (the image is uniform)");
  const double thr = dark + options.threshold * (bright - dark);

  auto at = [&](double x, double y) {  // bilinear, OpenCV coordinates; x, y inside [0, W-1] x [0, H-1]
    const int x0 = std::min(int(x), W - 2), y0 = std::min(int(y), H - 2);
    const double fx = x - x0, fy = y - y0;
    const float* r0 = &lum[size_t(y0) * W + x0];
    const float* r1 = r0 + W;
    return (1 - fy) * ((1 - fx) * r0[0] + fx * r0[1]) + fy * ((1 - fx) * r1[0] + fx * r1[1]);
  };

  double cx = 0, cy = 0, n = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (lum[size_t(y) * W + x] > thr) {
        cx += x;
        cy += y;
        n += 1;
      }
  if (n == 0) throw InputError("find_image_circle: no bright disc found");
  cx /= n;
  cy /= n;

  ImageCircle result;
  const double step = 0.25;
  for (int pass = 0; pass < 2; ++pass) {
    std::vector<Pt> pts;
    for (int k = 0; k < options.rays; ++k) {
      const double a = 2 * M_PI * (k + 0.5) / options.rays;
      const double dx = std::cos(a), dy = std::sin(a);
      // Samples along the ray until it leaves the image.
      std::vector<double> s;
      for (double t = 0;; t += step) {
        const double x = cx + t * dx, y = cy + t * dy;
        if (x < 0 || y < 0 || x > W - 1 || y > H - 1) break;
        s.push_back(at(x, y));
      }
      if (s.size() < 8) continue;
      // Outermost lit -> dark crossing; none if the ray ends lit (circle cropped there).
      if (s.back() > thr) continue;
      int last_lit = -1;
      for (int i = int(s.size()) - 2; i >= 0; --i)
        if (s[i] > thr) {
          last_lit = i;
          break;
        }
      if (last_lit < 0) continue;
      // Local levels 3 px inside and outside; edge at their half level.
      const int m = int(3 / step);
      const int in_i = std::max(0, last_lit - m), out_i = std::min(int(s.size()) - 1, last_lit + m);
      const double mid = 0.5 * (s[in_i] + s[out_i]);
      int j = -1;
      for (int i = out_i - 1; i >= in_i; --i)
        if (s[i] >= mid && s[i + 1] < mid) {
          j = i;
          break;
        }
      if (j < 0) continue;
      const double f = (s[j] - mid) / (s[j] - s[j + 1]);
      const double t = (j + f) * step;
      pts.push_back({cx + t * dx, cy + t * dy});
    }
    double fx, fy, fr;
    if (!fit_circle(pts, &fx, &fy, &fr))
      throw InputError("find_image_circle: no disc boundary found (is the image circle inside the frame?)");
    // Reject outliers at 3 MAD of the radial residual, refit.
    std::vector<double> res(pts.size());
    for (size_t i = 0; i < pts.size(); ++i) res[i] = std::hypot(pts[i].x - fx, pts[i].y - fy) - fr;
    const double med = median_of(res);
    std::vector<double> dev(res.size());
    for (size_t i = 0; i < res.size(); ++i) dev[i] = std::abs(res[i] - med);
    const double mad = std::max(1.4826 * median_of(dev), 0.05);
    std::vector<Pt> kept;
    for (size_t i = 0; i < pts.size(); ++i)
      if (std::abs(res[i] - med) <= 3 * mad) kept.push_back(pts[i]);
    if (!fit_circle(kept, &fx, &fy, &fr))
      throw InputError("find_image_circle: no disc boundary found (is the image circle inside the frame?)");
    double ss = 0;
    for (const Pt& q : kept) {
      const double d = std::hypot(q.x - fx, q.y - fy) - fr;
      ss += d * d;
    }
    result = {fx, fy, fr, std::sqrt(ss / kept.size()), int(kept.size())};
    cx = fx;
    cy = fy;
  }
  return result;
}

}  // namespace lp
