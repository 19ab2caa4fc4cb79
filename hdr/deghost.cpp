#include "hdr/deghost.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/error.h"
#include "hdr/align.h"

namespace lp {
namespace {

// Code value -> log exposure g(z) and its slope dg/dz, for one channel.
class LogCurve {
 public:
  explicit LogCurve(const std::vector<float>* table) : table_(table) {}
  double g(double z) const {
    if (!table_) return std::log(std::max(z, 1e-6));
    const auto& t = *table_;
    const double k = std::clamp(z, 0.0, 1.0) * double(t.size() - 1);
    const size_t k0 = std::min(size_t(k), t.size() - 2);
    const double f = k - double(k0);
    return (1 - f) * t[k0] + f * t[k0 + 1];
  }
  double slope(double z) const {
    if (!table_) return 1.0 / std::max(z, 1e-6);
    const double h = 1.0 / double(table_->size() - 1);
    const double a = std::max(0.0, z - h), b = std::min(1.0, z + h);
    return (g(b) - g(a)) / (b - a);
  }

 private:
  const std::vector<float>* table_;
};

void check_inputs(const std::vector<RgbImage>& frames, const std::vector<double>& times,
                  const LogResponse* response, const DeghostOptions& o) {
  if (frames.empty()) throw InputError("deghost: no frames");
  if (frames.size() != times.size())
    throw InputError("deghost: " + std::to_string(frames.size()) + " frames but " + std::to_string(times.size()) +
                     " exposure times");
  for (size_t i = 0; i < frames.size(); ++i) {
    const RgbImage& f = frames[i];
    if (f.width <= 0 || f.height <= 0 || f.rgb.size() != size_t(f.width) * f.height * 3)
      throw InputError("deghost: frame " + std::to_string(i) + " is empty or its pixel count does not match its size");
    if (f.width != frames[0].width || f.height != frames[0].height)
      throw InputError("deghost: frame " + std::to_string(i) + " differs in size from frame 0");
    if (!f.valid.empty() && f.valid.size() != size_t(f.width) * f.height)
      throw InputError("deghost: frame " + std::to_string(i) + " has a validity mask of the wrong size");
    if (!(times[i] > 0) || !std::isfinite(times[i]))
      throw InputError("deghost: exposure time of frame " + std::to_string(i) + " is not positive");
  }
  if (response) {
    for (int c = 0; c < 3; ++c) {
      const auto& t = (*response)[size_t(c)];
      if (t.size() < 2) throw InputError("deghost: response channel " + std::to_string(c) + " has fewer than 2 entries");
      for (size_t k = 0; k < t.size(); ++k) {
        if (!std::isfinite(t[k]))
          throw InputError("deghost: response channel " + std::to_string(c) + " entry " + std::to_string(k) +
                           " is not finite");
        if (k > 0 && t[k] < t[k - 1])
          throw InputError("deghost: response channel " + std::to_string(c) + " decreases at entry " +
                           std::to_string(k));
      }
    }
  }
  if (o.reference >= int(frames.size()))
    throw InputError("deghost: reference " + std::to_string(o.reference) + " is not a frame index");
  if (!(o.black_code < o.saturated_code))
    throw InputError("deghost: black_code must be below saturated_code");
  if (o.relative_threshold < 0 || o.noise_sigma < 0 || o.noise_k < 0 || o.dilate_px < 0)
    throw InputError("deghost: thresholds, noise and dilate_px must not be negative");
}

}  // namespace

std::vector<std::vector<uint8_t>> ghost_masks(const std::vector<RgbImage>& frames,
                                              const std::vector<double>& exposure_seconds,
                                              const LogResponse* response, const DeghostOptions& o) {
  check_inputs(frames, exposure_seconds, response, o);
  const size_t n = frames.size();
  const int w = frames[0].width, h = frames[0].height;
  const size_t npix = size_t(w) * h;
  const size_t ref = o.reference >= 0 ? size_t(o.reference) : middle_exposure_index(exposure_seconds);

  // Anchor candidates: the reference, then (where the reference pixel is invalid) the other
  // frames by distance in exposure order.
  std::vector<size_t> order(n);
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return exposure_seconds[a] < exposure_seconds[b]; });
  std::vector<long> rank(n);
  for (size_t r = 0; r < n; ++r) rank[order[r]] = long(r);
  std::vector<size_t> anchors = order;
  std::stable_sort(anchors.begin(), anchors.end(), [&](size_t a, size_t b) {
    return std::abs(rank[a] - rank[ref]) < std::abs(rank[b] - rank[ref]);
  });

  const std::array<LogCurve, 3> curves = {LogCurve(response ? &(*response)[0] : nullptr),
                                          LogCurve(response ? &(*response)[1] : nullptr),
                                          LogCurve(response ? &(*response)[2] : nullptr)};
  std::array<double, 3> g_black{}, g_sat{};
  // A clipped code bounds the radiance, up to the code noise: black means at most
  // black_code + k sigma, saturated at least saturated_code - k sigma.
  const double code_tol = o.noise_k * o.noise_sigma;
  for (int c = 0; c < 3; ++c) {
    g_black[c] = curves[c].g(std::min(1.0, o.black_code + code_tol));
    g_sat[c] = curves[c].g(std::max(0.0, o.saturated_code - code_tol));
  }
  std::vector<double> log_t(n);
  for (size_t i = 0; i < n; ++i) log_t[i] = std::log(exposure_seconds[i]);
  const double base_tol = std::log1p(o.relative_threshold);
  constexpr double kInf = std::numeric_limits<double>::infinity();

  auto valid = [&](size_t f, size_t p) { return frames[f].valid.empty() || frames[f].valid[p] != 0; };

  // What one code of frame f says about the exposure-normalised log radiance of channel c:
  // the interval [lo, hi] (a point for a usable code, a half-line for a clipped one) and the
  // noise s of a point (clipped bounds carry their noise in g_black / g_sat already).
  struct Interval {
    double lo, hi, s;
  };
  auto interval = [&](size_t f, int c, double z) -> Interval {
    if (z >= o.saturated_code) return {g_sat[size_t(c)] - log_t[f], kInf, 0.0};
    if (z <= o.black_code) return {-kInf, g_black[size_t(c)] - log_t[f], 0.0};
    const double v = curves[size_t(c)].g(z) - log_t[f];
    return {v, v, o.noise_sigma * curves[size_t(c)].slope(z)};
  };
  // Two statements contradict each other when one's lower end lies above the other's upper
  // end by more than the tolerance; two bounds on the same side never do.
  auto contradict = [&](const Interval& a, const Interval& b) {
    const double tol = base_tol + o.noise_k * std::sqrt(a.s * a.s + b.s * b.s);
    return a.lo - b.hi > tol || b.lo - a.hi > tol;
  };

  std::vector<std::vector<uint8_t>> keep(n, std::vector<uint8_t>(npix, 1));
  std::vector<cv::Mat> ghost(n);
  for (size_t i = 0; i < n; ++i) ghost[i] = cv::Mat::zeros(h, w, CV_8UC1);

  for (size_t p = 0; p < npix; ++p) {
    size_t anchor = n;
    for (size_t a : anchors)
      if (valid(a, p)) {
        anchor = a;
        break;
      }
    const float* za = anchor < n ? &frames[anchor].rgb[3 * p] : nullptr;
    std::array<Interval, 3> ia{};
    if (za)
      for (int c = 0; c < 3; ++c) ia[size_t(c)] = interval(anchor, c, za[c]);
    for (size_t i = 0; i < n; ++i) {
      if (!valid(i, p)) {
        keep[i][p] = 0;
        continue;
      }
      if (anchor == n || i == anchor || i == ref) continue;
      const float* zi = &frames[i].rgb[3 * p];
      bool disagree = false;
      for (int c = 0; c < 3 && !disagree; ++c) disagree = contradict(interval(i, c, zi[c]), ia[size_t(c)]);
      if (disagree) ghost[i].data[p] = 1;
    }
  }

  const cv::Mat kernel =
      o.dilate_px > 0 ? cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * o.dilate_px + 1, 2 * o.dilate_px + 1))
                      : cv::Mat();
  for (size_t i = 0; i < n; ++i) {
    if (i == ref) continue;
    cv::Mat g = ghost[i];
    if (o.dilate_px > 0) cv::dilate(ghost[i], g, kernel);
    for (size_t p = 0; p < npix; ++p)
      if (g.data[p]) keep[i][p] = 0;
  }
  return keep;
}

std::vector<size_t> count_dropped(const std::vector<std::vector<uint8_t>>& masks) {
  std::vector<size_t> out;
  out.reserve(masks.size());
  for (const auto& m : masks) out.push_back(size_t(std::count(m.begin(), m.end(), uint8_t(0))));
  return out;
}

}  // namespace lp
