#include "hdr/hdr_accuracy.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"

namespace lp {
namespace {
double luminance_of(const float* p) { return 0.2126 * double(p[0]) + 0.7152 * double(p[1]) + 0.0722 * double(p[2]); }
}  // namespace

HdrError hdr_log_error(const RgbImage& estimate, const RgbImage& truth,
                       const std::optional<std::vector<uint8_t>>& mask) {
  const size_t pixels = size_t(truth.width) * size_t(truth.height);
  auto size_text = [](const RgbImage& i) { return std::to_string(i.width) + "x" + std::to_string(i.height); };
  if (estimate.width != truth.width || estimate.height != truth.height)
    throw InputError("hdr error: estimate is " + size_text(estimate) + ", truth is " + size_text(truth));
  if (estimate.rgb.size() != 3 * pixels || truth.rgb.size() != 3 * pixels)
    throw InputError("hdr error: an image's pixel data does not match its size");
  if (mask && mask->size() != pixels)
    throw InputError("hdr error: the mask has " + std::to_string(mask->size()) + " entries for " +
                     std::to_string(pixels) + " pixels");

  HdrError out;
  std::vector<double> log_ratio;  // log10(Y_truth / Y_estimate)
  log_ratio.reserve(pixels);
  for (size_t i = 0; i < pixels; ++i) {
    if (mask && !(*mask)[i]) continue;
    if (!truth.valid.empty() && !truth.valid[i]) continue;
    const double yt = luminance_of(&truth.rgb[3 * i]);
    if (!std::isfinite(yt) || !(yt > 0)) {
      ++out.pixels_truth_dark;
      continue;
    }
    const double ye = luminance_of(&estimate.rgb[3 * i]);
    if ((!estimate.valid.empty() && !estimate.valid[i]) || !std::isfinite(ye) || !(ye > 0)) {
      ++out.pixels_invalid;
      continue;
    }
    log_ratio.push_back(std::log10(yt) - std::log10(ye));
  }
  if (log_ratio.empty())
    throw InputError("hdr error: no pixel to compare (" + std::to_string(out.pixels_invalid) +
                     " invalid in the estimate)");
  out.pixels_compared = log_ratio.size();

  std::vector<double> sorted = log_ratio;
  const size_t n = sorted.size();
  std::nth_element(sorted.begin(), sorted.begin() + n / 2, sorted.end());
  double s = sorted[n / 2];
  if (n % 2 == 0) s = 0.5 * (s + *std::max_element(sorted.begin(), sorted.begin() + n / 2));
  out.global_scale = std::pow(10.0, s);

  std::vector<double> err(n);
  for (size_t i = 0; i < n; ++i) err[i] = std::abs(log_ratio[i] - s);
  std::sort(err.begin(), err.end());
  out.median_log10 = n % 2 ? err[n / 2] : 0.5 * (err[n / 2 - 1] + err[n / 2]);
  const size_t rank = size_t(std::ceil(0.95 * double(n)));
  out.p95_log10 = err[std::max<size_t>(rank, 1) - 1];
  return out;
}

}  // namespace lp
