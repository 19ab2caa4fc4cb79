#include "hdr/align.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numeric>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include "core/error.h"
#include "core/lazy_libs.h"

namespace lp {
namespace {

// Codes inside (kDark, kBright) are trusted for the ECC image; outside they are clamped.
constexpr double kDark = 0.02, kBright = 0.95;
constexpr double kGamma = 2.2;  // rough linearisation when no response is known

void check_frames(const std::vector<RgbImage>& frames, const std::vector<double>& times) {
  if (frames.empty()) throw InputError("align: no frames");
  if (frames.size() != times.size())
    throw InputError("align: " + std::to_string(frames.size()) + " frames but " + std::to_string(times.size()) +
                     " exposure times");
  for (size_t i = 0; i < frames.size(); ++i) {
    const RgbImage& f = frames[i];
    if (f.width <= 0 || f.height <= 0 || f.rgb.size() != size_t(f.width) * f.height * 3)
      throw InputError("align: frame " + std::to_string(i) + " is empty or its pixel count does not match its size");
    if (f.width != frames[0].width || f.height != frames[0].height)
      throw InputError("align: frame " + std::to_string(i) + " is " + std::to_string(f.width) + "x" +
                       std::to_string(f.height) + ", frame 0 is " + std::to_string(frames[0].width) + "x" +
                       std::to_string(frames[0].height));
    if (!f.valid.empty() && f.valid.size() != size_t(f.width) * f.height)
      throw InputError("align: frame " + std::to_string(i) + " has a validity mask of the wrong size");
    if (!(times[i] > 0) || !std::isfinite(times[i]))
      throw InputError("align: exposure time of frame " + std::to_string(i) + " is not positive");
  }
}

// Grey codes for Mtb. Pixels that take no part (invalid, or of the ignored colour) are set to
// the median of the others: Mtb's exclusion bitmap leaves out every pixel within a few codes
// of the median, so they neither match nor mismatch anything.
cv::Mat grey8(const RgbImage& f, const std::optional<std::array<uint8_t, 3>>& ignore = std::nullopt) {
  cv::Mat out(f.height, f.width, CV_8UC1);
  const size_t n = size_t(f.width) * f.height;
  auto* dst = out.ptr<uint8_t>();
  std::vector<char> skip(n, 0);
  size_t skipped = 0;
  for (size_t i = 0; i < n; ++i) {
    const float m = (f.rgb[3 * i] + f.rgb[3 * i + 1] + f.rgb[3 * i + 2]) * (255.0f / 3.0f);
    dst[i] = cv::saturate_cast<uint8_t>(m);
    bool out_of_match = !f.valid.empty() && !f.valid[i];
    if (ignore) {
      bool same = true;
      for (int c = 0; c < 3; ++c) same = same && std::lround(f.rgb[3 * i + size_t(c)] * 255.0f) == (*ignore)[size_t(c)];
      out_of_match = out_of_match || same;
    }
    skip[i] = out_of_match;
    skipped += out_of_match;
  }
  if (skipped == 0 || skipped == n) return out;
  std::array<size_t, 256> histogram{};
  for (size_t i = 0; i < n; ++i)
    if (!skip[i]) ++histogram[dst[i]];
  size_t below = 0, median = 0;
  for (; median < 255 && 2 * (below + histogram[median]) < n - skipped; ++median) below += histogram[median];
  for (size_t i = 0; i < n; ++i)
    if (skip[i]) dst[i] = uint8_t(median);
  return out;
}

// Mtb's threshold and exclusion bitmaps of one grey image at full resolution.
struct MtbBitmaps {
  cv::Mat threshold, exclusion;
};
MtbBitmaps mtb_bitmaps(cv::AlignMTB& mtb, const cv::Mat& grey) {
  MtbBitmaps b;
  mtb.computeBitmaps(grey, b.threshold, b.exclusion);
  return b;
}

// Ward's Mtb error at full resolution: the pixels whose threshold bits differ between the
// reference and the frame moved by `shift`, among those both exclusion bitmaps keep; a
// reference pixel the move leaves without a counterpart (shifted in from outside, or
// excluded in the frame) counts as half a mismatch, what a random bit would give, so that a
// shift cannot score well by moving the structure out of the comparison.
double mtb_mismatch(cv::AlignMTB& mtb, const MtbBitmaps& ref, const MtbBitmaps& frame, cv::Point shift) {
  cv::Mat moved_tb, moved_eb;
  mtb.shiftMat(frame.threshold, moved_tb, shift);
  mtb.shiftMat(frame.exclusion, moved_eb, shift);  // pixels shifted in from outside are 0: not kept
  cv::Mat kept, differ;
  cv::bitwise_and(ref.exclusion, moved_eb, kept);
  cv::bitwise_xor(ref.threshold, moved_tb, differ);
  cv::bitwise_and(differ, kept, differ);
  return double(cv::countNonZero(differ)) + 0.5 * double(cv::countNonZero(ref.exclusion) - cv::countNonZero(kept));
}

// Linear-ish luminance (code^2.2), not yet divided by the exposure time.
cv::Mat linear_luma(const RgbImage& f) {
  cv::Mat out(f.height, f.width, CV_32FC1);
  const size_t n = size_t(f.width) * f.height;
  auto* dst = out.ptr<float>();
  for (size_t i = 0; i < n; ++i) {
    const float m = std::clamp((f.rgb[3 * i] + f.rgb[3 * i + 1] + f.rgb[3 * i + 2]) / 3.0f, 0.0f, 1.0f);
    dst[i] = std::pow(m, float(kGamma));
  }
  return out;
}

// log(clamp(lin / t, lo, hi)) as CV_32F.
cv::Mat clamped_log(const cv::Mat& lin, double t, double lo, double hi) {
  cv::Mat out(lin.size(), CV_32FC1);
  const float scale = float(1.0 / t), flo = float(lo), fhi = float(hi);
  for (int y = 0; y < lin.rows; ++y) {
    const float* s = lin.ptr<float>(y);
    float* d = out.ptr<float>(y);
    for (int x = 0; x < lin.cols; ++x) d[x] = std::log(std::clamp(s[x] * scale, flo, fhi));
  }
  return out;
}

// Warps `f` by frame(M p) -> out(p); pixels not fully inside the valid source become invalid.
RgbImage warp_frame(const RgbImage& f, const cv::Mat& M) {
  RgbImage out;
  out.width = f.width;
  out.height = f.height;
  out.units = f.units;
  out.rgb.assign(f.rgb.size(), 0.0f);
  const cv::Mat src(f.height, f.width, CV_32FC3, const_cast<float*>(f.rgb.data()));
  cv::Mat dst(f.height, f.width, CV_32FC3, out.rgb.data());
  const int flags = cv::INTER_LINEAR | cv::WARP_INVERSE_MAP;
  cv::warpAffine(src, dst, M, dst.size(), flags, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  CV_Assert(dst.data == reinterpret_cast<uchar*>(out.rgb.data()));

  cv::Mat mask(f.height, f.width, CV_32FC1);
  if (f.valid.empty()) {
    mask.setTo(1.0f);
  } else {
    for (int y = 0; y < f.height; ++y)
      for (int x = 0; x < f.width; ++x) mask.at<float>(y, x) = f.valid[size_t(y) * f.width + x] ? 1.0f : 0.0f;
  }
  cv::Mat warped_mask;
  cv::warpAffine(mask, warped_mask, M, mask.size(), flags, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  out.valid.resize(size_t(f.width) * f.height);
  for (int y = 0; y < f.height; ++y) {
    const float* m = warped_mask.ptr<float>(y);
    for (int x = 0; x < f.width; ++x) {
      const bool ok = m[x] > 0.999f;
      out.valid[size_t(y) * f.width + x] = ok ? 1 : 0;
      if (!ok) std::fill_n(&out.rgb[(size_t(y) * f.width + x) * 3], 3, 0.0f);
    }
  }
  return out;
}

}  // namespace

size_t middle_exposure_index(const std::vector<double>& exposure_seconds) {
  if (exposure_seconds.empty()) throw InputError("align: no exposure times");
  std::vector<size_t> order(exposure_seconds.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::stable_sort(order.begin(), order.end(),
                   [&](size_t a, size_t b) { return exposure_seconds[a] < exposure_seconds[b]; });
  return order[(order.size() - 1) / 2];
}

int default_max_shift_px(int width, int height) {
  return std::max(32, int(std::lround(0.025 * std::max(width, height))));
}

std::vector<RgbImage> align_frames(const std::vector<RgbImage>& frames, const std::vector<double>& exposure_seconds,
                                   const AlignOptions& given, AlignReport* report) {
  const auto start = std::chrono::steady_clock::now();
  check_frames(frames, exposure_seconds);
  if (given.max_shift_px < 0) throw InputError("align: max_shift_px must be at least 1 (0: automatic)");
  AlignOptions options = given;
  if (options.max_shift_px == 0) options.max_shift_px = default_max_shift_px(frames[0].width, frames[0].height);

  const size_t n = frames.size();
  const size_t ref = middle_exposure_index(exposure_seconds);
  // Each pyramid level doubles the reach; the coarsest level keeps at least 8 px on its
  // short side (coarser bitmaps carry too little structure and lock onto wrong shifts).
  const int wanted_bits = std::max(1, int(std::ceil(std::log2(double(options.max_shift_px) + 1.0))));
  const int short_side = std::min(frames[0].width, frames[0].height);
  const int max_bits = std::clamp(int(std::floor(std::log2(short_side / 8.0))), 1, wanted_bits);
  cv::Ptr<cv::AlignMTB> mtb = cv::createAlignMTB(max_bits);

  const cv::Mat ref_grey = grey8(frames[ref], options.ignore_colour);
  MtbBitmaps ref_bitmaps;  // made when a shift needs checking (mtb_mismatch)
  cv::Mat ref_lin;
  if (options.method == AlignOptions::Method::Ecc) ref_lin = linear_luma(frames[ref]);
  const double dark_lin = std::pow(kDark, kGamma), bright_lin = std::pow(kBright, kGamma);

  std::vector<std::array<double, 3>> shifts(n, {0.0, 0.0, 0.0});
  std::vector<bool> converged(n, true);
  std::vector<RgbImage> out(n);
  for (size_t i = 0; i < n; ++i) {
    if (i == ref) {
      out[i] = frames[i];
      continue;
    }
    // calculateShift(ref, frame) is the shift that moves the frame onto the reference,
    // i.e. minus the frame's motion.
    const cv::Mat frame_grey = grey8(frames[i], options.ignore_colour);
    cv::Point s = mtb->calculateShift(ref_grey, frame_grey);
    // Mtb's coarse levels can lock onto a wrong shift where one frame is mostly black or
    // white (Memorial's 1/16 s frame against its 1/4 s one: "moved by (39, 9) px" on registered
    // frames). Checked at full resolution against not moving at all: the one with fewer
    // mismatched bits (Ward's own error) wins.
    if (s != cv::Point(0, 0)) {
      if (ref_bitmaps.threshold.empty()) ref_bitmaps = mtb_bitmaps(*mtb, ref_grey);
      const MtbBitmaps frame_bitmaps = mtb_bitmaps(*mtb, frame_grey);
      if (mtb_mismatch(*mtb, ref_bitmaps, frame_bitmaps, {0, 0}) <= mtb_mismatch(*mtb, ref_bitmaps, frame_bitmaps, s))
        s = {0, 0};
    }
    double dx = -s.x, dy = -s.y, angle = 0.0;
    if (std::max(std::abs(dx), std::abs(dy)) > options.max_shift_px)
      throw InputError("align: frame " + std::to_string(i) + " moved by (" + std::to_string(int(dx)) + ", " +
                       std::to_string(int(dy)) + ") px, more than the " + std::to_string(options.max_shift_px) +
                       " px searched (--max-shift)");

    if (options.method == AlignOptions::Method::Ecc) {
      const double tr = exposure_seconds[ref], ti = exposure_seconds[i];
      const double lo = std::max(dark_lin / tr, dark_lin / ti), hi = std::min(bright_lin / tr, bright_lin / ti);
      bool ok = false;
      if (lo < hi) {
        const cv::Mat tmpl = clamped_log(ref_lin, tr, lo, hi);
        const cv::Mat input = clamped_log(linear_luma(frames[i]), ti, lo, hi);
        cv::Mat W = (cv::Mat_<float>(2, 3) << 1, 0, float(dx), 0, 1, float(dy));
        const int motion = options.rotation ? lazy::kMotionEuclidean : lazy::kMotionTranslation;
        try {
          lazy::find_transform_ecc(tmpl, input, W, motion,
                                   cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 200, 1e-6), 5);
          const double ex = W.at<float>(0, 2), ey = W.at<float>(1, 2);
          const double ea = std::atan2(double(W.at<float>(1, 0)), double(W.at<float>(0, 0)));
          if (std::isfinite(ex) && std::isfinite(ey) && std::isfinite(ea) &&
              std::max(std::abs(ex), std::abs(ey)) <= options.max_shift_px) {
            dx = ex;
            dy = ey;
            angle = ea;
            ok = true;
          }
        } catch (const cv::Exception&) {
          // Not converged: keep the Mtb shift.
        }
      }
      converged[i] = ok;
    }
    shifts[i] = {dx, dy, angle};
    const double c = std::cos(angle), sn = std::sin(angle);
    const cv::Mat M = (cv::Mat_<double>(2, 3) << c, -sn, dx, sn, c, dy);
    out[i] = warp_frame(frames[i], M);
  }

  if (report) {
    report->shift_per_frame = shifts;
    report->ecc_converged = converged;
    report->reference = ref;
    report->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return out;
}

}  // namespace lp
