#include "hdr/merge.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <numeric>
#include <type_traits>

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "core/error.h"
#include "core/thread_arena.h"
#include "hdr/merge_kernel.h"

namespace lp {
namespace {

struct Tables {
  int levels = 0;
  float scale = 0.0f;                           // code value -> level (before + 0.5)
  std::array<std::vector<float>, 3> w, wx;      // hat(l), hat(l) * exp(g_c(l))
  std::vector<float> w3, wx3;                   // the same, channel-major in one table (the kernel's)
  std::vector<uint64_t> w_wx3;                  // w3 and wx3 paired (merge_kernel.h)
  std::vector<float> bound_short, bound_long;   // float(exp(g_c(l)) / t_k) of the shortest / longest frame
  std::vector<uint8_t> planes;                  // 256 levels: w3, wx3 and the bounds as byte planes (merge_kernel.h)
  bool one_table = false;                       // w3 and wx3 the same for the three channels (merge_kernel.h)
  bool simd = false;                            // MergeOptions::simd
  std::vector<float> frame_w, frame_wx;         // per frame: s_k and s_k / t_k
  std::vector<size_t> by_time;                  // frame indices, shortest exposure first
  int sat_level = 0, black_level = 0;           // level >= sat_level: saturated; <= black_level: black
  int zero_through = -1, zero_from = 0;         // levels of w = wx = 0 in every channel (merge_kernel.h)
  std::array<int, 3> colour_level{-1, -1, -1};  // ignore_colour in levels, or -1
  std::vector<const uint8_t*> keep, valid;      // per frame: frame_masks[k] / frames[k].valid, or null
  std::vector<size_t> valid_stride;             // per frame: bytes between the valid mask's rows
};

inline int level_of(float v, float scale, int levels) {
  const float s = v * scale + 0.5f;
  if (!(s > 0.0f)) return 0;  // also NaN
  // Clamped before the conversion: int(s) of a value beyond int's range (an infinite code) is
  // undefined. The same order as the vector kernel (merge_kernel.cpp).
  return int(std::min(s, float(levels - 1)));
}

// kIgnore: ignore_colour is set. kMask: some frame has a keep mask (frame_masks) or a valid
// mask; kCodes: the levels come from BracketView::codes (256 levels) instead of the floats.
// All are chosen once per call, so the plain merge carries none of the tests.
template <bool kIgnore, bool kMask, bool kCodes>
void merge_rows(const BracketView& b, const CameraResponse& resp, const Tables& T, int y0, int y1, RgbImage& out,
                uint8_t* flags, std::atomic<size_t>& n_sat, std::atomic<size_t>& n_black,
                std::atomic<size_t>& n_ignored, std::atomic<size_t>& n_no_frame, std::atomic<size_t>& n_well) {
  constexpr bool kTrack = kIgnore || kMask;
  const int W = b.frames[0].width;
  const size_t nf = b.frames.size();
  const int L = T.levels;
  const float scale = T.scale;
  // Sized at the first use: the kernel leaves the scalar loop nothing in most rows, and
  // zeroing these per task was 4 % of the benchmark's merge on one thread.
  std::vector<float> sw, swx;
  // kTrack, per pixel: bit 1 some frame was kept (mask), bit 2 some kept frame was not ignore_colour.
  std::vector<uint8_t> used;
  if constexpr (kTrack) used.resize(size_t(W));
  const float* w0 = T.w[0].data();
  const float* w1 = T.w[1].data();
  const float* w2 = T.w[2].data();
  const float* x0 = T.wx[0].data();
  const float* x1 = T.wx[1].data();
  const float* x2 = T.wx[2].data();
  // The level of channel c of frame k at pixel (x, y).
  auto level_at = [&](size_t k, int x, int y, int c) -> int {
    if constexpr (kCodes)
      return b.codes[k][3 * (size_t(y) * size_t(W) + size_t(x)) + size_t(c)];
    else
      return level_of(b.frames[k].pixel(x, y)[c], scale, L);
  };
  // Frame k does not take part at pixel (x, y).
  auto dropped = [&](size_t k, int x, int y) {
    if constexpr (kMask) {
      if ((T.keep[k] && !T.keep[k][size_t(y) * size_t(W) + size_t(x)]) ||
          (T.valid[k] && !T.valid[k][size_t(y) * T.valid_stride[k] + size_t(x)]))
        return true;
    }
    if constexpr (kIgnore) {
      if (level_at(k, x, y, 0) == T.colour_level[0] && level_at(k, x, y, 1) == T.colour_level[1] &&
          level_at(k, x, y, 2) == T.colour_level[2])
        return true;
    }
    return false;
  };
  size_t sat = 0, black = 0, ignored = 0, no_frame = 0, well = 0;
  // The unmasked merge runs the vector kernel over most of a row (merge_kernel.h) and the
  // loops below over the rest: the tail of the row and the pixels it hands back.
  [[maybe_unused]] std::vector<const float*> frame_rows(nf);
  [[maybe_unused]] std::vector<const uint8_t*> code_rows(nf);
  [[maybe_unused]] std::vector<uint32_t> redo;
  [[maybe_unused]] detail::MergeRowInput kernel;
  if constexpr (!kTrack) {
    redo.resize(size_t(W));
    kernel = {frame_rows.data(), kCodes ? code_rows.data() : nullptr, T.frame_w.data(), T.frame_wx.data(), nf,
              size_t(W), T.w3.data(), T.wx3.data(), T.w_wx3.data(), L, T.zero_through, T.zero_from, T.sat_level,
              T.black_level, T.by_time.front(), T.by_time.back(), T.bound_short.data(), T.bound_long.data(),
              T.planes.empty() ? nullptr : T.planes.data(), T.one_table};
  }
  for (int y = y0; y < y1; ++y) {
    const size_t row = size_t(y) * size_t(W);
    float* o = &out.rgb[3 * row];
    // Sums of weights and weighted radiance over the frames for pixels [begin, end), in frame order.
    auto accumulate = [&](int begin, int end) {
      if (sw.empty()) sw.resize(3 * size_t(W)), swx.resize(3 * size_t(W));
      std::fill(sw.begin() + 3 * begin, sw.begin() + 3 * end, 0.0f);
      std::fill(swx.begin() + 3 * begin, swx.begin() + 3 * end, 0.0f);
      if constexpr (kTrack) std::fill(used.begin() + begin, used.begin() + end, uint8_t(0));
      for (size_t k = 0; k < nf; ++k) {
        [[maybe_unused]] const float* z = nullptr;
        [[maybe_unused]] const uint8_t* zc = nullptr;
        if constexpr (kCodes)
          zc = b.codes[k] + 3 * row;
        else
          z = b.frames[k].row(y);
        const float fw = T.frame_w[k], fx = T.frame_wx[k];
        [[maybe_unused]] const uint8_t* km = nullptr;
        [[maybe_unused]] const uint8_t* vm = nullptr;
        if constexpr (kMask) {
          km = T.keep[k] ? T.keep[k] + row : nullptr;
          vm = T.valid[k] ? T.valid[k] + size_t(y) * T.valid_stride[k] : nullptr;
        }
        for (int x = begin; x < end; ++x) {
          if constexpr (kMask) {
            if ((km && !km[x]) || (vm && !vm[x])) continue;
          }
          int l0, l1, l2;
          if constexpr (kCodes) {
            l0 = zc[3 * x], l1 = zc[3 * x + 1], l2 = zc[3 * x + 2];
          } else {
            l0 = level_of(z[3 * x], scale, L), l1 = level_of(z[3 * x + 1], scale, L), l2 = level_of(z[3 * x + 2], scale, L);
          }
          if constexpr (kIgnore) {
            if (l0 == T.colour_level[0] && l1 == T.colour_level[1] && l2 == T.colour_level[2]) {
              used[size_t(x)] |= 1;
              continue;
            }
          }
          if constexpr (kTrack) used[size_t(x)] = 3;
          float* a = &sw[3 * size_t(x)];
          float* c = &swx[3 * size_t(x)];
          a[0] += w0[l0] * fw;
          a[1] += w1[l1] * fw;
          a[2] += w2[l2] * fw;
          c[0] += x0[l0] * fx;
          c[1] += x1[l1] * fx;
          c[2] += x2[l2] * fx;
        }
      }
    };
    // The output of pixels [begin, end) from their sums, with the fallbacks of channels no frame weighs.
    auto finish = [&](int begin, int end) {
      for (int x = begin; x < end; ++x) {
        if constexpr (kTrack) {
          if (!(used[size_t(x)] & 2)) {
            out.valid[row + size_t(x)] = 0;
            o[3 * x] = o[3 * x + 1] = o[3 * x + 2] = 0.0f;
            if (used[size_t(x)] & 1)
              ++ignored;
            else
              ++no_frame;
            if (flags) flags[row + size_t(x)] = 0;
            continue;
          }
        }
        uint8_t flag = 0;
        for (int c = 0; c < 3; ++c) {
          const size_t i = 3 * size_t(x) + size_t(c);
          if (sw[i] > 0.0f) {
            o[i] = swx[i] / sw[i];
            continue;
          }
          // No usable frame for this channel (rare): classify the kept frames and take a bound.
          bool all_sat = true, all_black = true;
          size_t best = nf;
          int best_d = 1 << 30;
          for (size_t k : T.by_time) {
            if constexpr (kTrack) {
              if (dropped(k, x, y)) continue;
            }
            const int l = level_at(k, x, y, c);
            all_sat = all_sat && l >= T.sat_level;
            all_black = all_black && l <= T.black_level;
            const int d = std::abs(2 * l - (L - 1));
            if (d < best_d) best_d = d, best = k;
          }
          size_t pick = best;
          if (all_sat || all_black) {  // shortest kept exposure (lower bound) / longest (upper bound)
            for (size_t j = 0; j < nf; ++j) {
              const size_t k = all_sat ? T.by_time[j] : T.by_time[nf - 1 - j];
              if constexpr (kTrack) {
                if (dropped(k, x, y)) continue;
              }
              pick = k;
              break;
            }
            flag |= all_sat ? kSaturatedEverywhere : kBlackEverywhere;
          }
          const int l = level_at(pick, x, y, c);
          o[i] = float(std::exp(double(resp.log_exposure[size_t(c)][size_t(l)])) / b.exposure_seconds[pick]);
        }
        if (flag & kSaturatedEverywhere) ++sat;
        if (flag & kBlackEverywhere) ++black;
        if (!flag) ++well;
        if (flags) flags[row + size_t(x)] = flag;
      }
    };
    int done = 0;
    if constexpr (!kTrack) {
      if (T.simd) {
        for (size_t k = 0; k < nf; ++k) {
          if constexpr (kCodes)
            code_rows[k] = b.codes[k] + 3 * row;
          else
            frame_rows[k] = b.frames[k].row(y);
        }
        // Flags go straight into the report's image (zeroed by the caller), or nowhere.
        const detail::MergeRowResult r = detail::merge_row_simd(kernel, o, flags ? flags + row : nullptr, redo.data());
        done = int(r.done);
        sat += r.saturated;
        black += r.black;
        well += r.done - r.redone - r.flagged;  // the redone pixels are counted by finish() below
        for (size_t i = 0; i < r.redone; ++i) {
          const int x = int(redo[i]);
          accumulate(x, x + 1);
          finish(x, x + 1);
        }
      }
    }
    accumulate(done, W);
    finish(done, W);
  }
  n_sat += sat;
  n_black += black;
  n_ignored += ignored;
  n_no_frame += no_frame;
  n_well += well;
}

}  // namespace

MergeWeights merge_weights(const CameraResponse& resp, int bit_depth, const std::vector<double>& exposure_seconds,
                           const MergeOptions& o) {
  check_response(resp, "response");
  if (exposure_seconds.empty()) throw InputError("merge weights: no exposure times");
  const int L = resp.levels;
  const double lo = o.black_threshold, hi = o.saturation_threshold;
  const MergeOptions::Weighting weighting = o.exposure_weighting ? o.weighting : MergeOptions::Weighting::Hat;
  const bool noise_aware = weighting == MergeOptions::Weighting::NoiseAware;
  if (noise_aware && (!(o.noise_full_well > 0.0) || !(o.noise_read_electrons >= 0.0)))
    throw InputError(fmt::format("merge noise model: need full well > 0 ({}) and read noise >= 0 ({})",
                                 o.noise_full_well, o.noise_read_electrons));
  MergeWeights mw;
  for (int c = 0; c < 3; ++c) {
    const std::vector<float>& g = resp.log_exposure[size_t(c)];
    // NoiseAware: 1 / var(ln E) per level (see MergeOptions).
    std::vector<double> inv_var(size_t(L), 1.0);
    if (noise_aware) {
      const int h = std::max(1, (L - 1) / 64);
      const int sat = std::clamp(int(std::lround(hi * (L - 1))), 0, L - 1);
      const double steps = std::pow(2.0, double(std::clamp(bit_depth, 1, 30))) - 1.0;
      const double q = 1.0 / std::min(steps, double(L - 1));  // one code step
      const double N = o.noise_full_well, r = o.noise_read_electrons;
      double top = 0.0;
      for (int l = 0; l < L; ++l) {
        const int a = std::max(0, l - h), e = std::min(L - 1, l + h);
        // g' per code unit (a code value in [0, 1] spans L - 1 levels); a non-monotone
        // stretch of a recovered curve is limited by the sensor terms alone.
        const double slope = std::max(0.0, double(g[size_t(e)] - g[size_t(a)]) / double(e - a) * double(L - 1));
        const double X = std::exp(std::min(double(g[size_t(l)] - g[size_t(sat)]), 50.0));
        const double var = slope * slope * q * q / 12.0 + 1.0 / (N * X) + (r * r) / (N * N * X * X);
        // var(E_k) = E_k^2 var(ln E_k) at the frame's own estimate E_k = exp(g) / t_k: the
        // level part here (exp(-2 g), relative to the saturation level), t_k^2 per frame below.
        const double rel = std::clamp(double(g[size_t(l)] - g[size_t(sat)]), -40.0, 40.0);
        inv_var[size_t(l)] = var > 0.0 && std::isfinite(var) ? std::exp(-2.0 * rel) / var : 0.0;
        top = std::max(top, inv_var[size_t(l)]);
      }
      // Normalised to a maximum of 1, floored so that no usable code underflows to weight 0.
      for (double& v : inv_var) v = std::max(top > 0.0 ? v / top : 0.0, 1e-30);
    }
    mw.level[size_t(c)].resize(size_t(L));
    for (int l = 0; l < L; ++l) {
      const double z = double(l) / double(L - 1);
      const double hat = (z <= lo || z >= hi) ? 0.0 : 1.0 - std::abs(2.0 * (z - lo) / (hi - lo) - 1.0);
      mw.level[size_t(c)][size_t(l)] = float(hat * inv_var[size_t(l)]);
    }
  }
  // Exposure factors relative to the longest exposure keep every product in float range.
  const double t_max = *std::max_element(exposure_seconds.begin(), exposure_seconds.end());
  for (double t : exposure_seconds)
    mw.frame.push_back(float(weighting == MergeOptions::Weighting::HatTimesExposure ? t / t_max
                             : noise_aware                                         ? (t / t_max) * (t / t_max)
                                                                                   : 1.0));
  return mw;
}

BracketView bracket_view(const Bracket& b) {
  BracketView v;
  for (const RgbImage& f : b.frames) v.frames.push_back(image_view(f));
  if (b.codes.size() == b.frames.size())
    for (const std::vector<uint8_t>& c : b.codes) v.codes.push_back(c.data());
  v.exposure_seconds = b.exposure_seconds;
  v.bit_depth = b.bit_depth;
  if (!b.paths.empty()) v.label = b.paths.front() + " .. " + b.paths.back();
  return v;
}

RgbImage merge_bracket(const Bracket& b, const CameraResponse& resp, const MergeOptions& o, MergeReport* report) {
  check_bracket(b);
  const size_t npix = size_t(b.width()) * size_t(b.height());
  for (size_t k = 0; k < b.frames.size(); ++k)
    if (!b.frames[k].valid.empty() && b.frames[k].valid.size() != npix)
      throw InputError(fmt::format("merge frame {}: valid mask of {} bytes, need width*height = {}", k,
                                   b.frames[k].valid.size(), npix));
  return merge_bracket(bracket_view(b), resp, o, report);
}

RgbImage merge_bracket(const BracketView& b, const CameraResponse& resp, const MergeOptions& o, MergeReport* report) {
  RgbImage out;
  merge_bracket(b, resp, o, &out, report);
  return out;
}

void merge_bracket(const BracketView& b, const CameraResponse& resp, const MergeOptions& o, RgbImage* out_image,
                   MergeReport* report) {
  if (!out_image) throw InputError(fmt::format("{}: no output image to merge into", b.label));
  const auto start = std::chrono::steady_clock::now();
  if (b.frames.size() < 2 || b.exposure_seconds.size() != b.frames.size())
    throw InputError(fmt::format("{}: {} frames and {} exposure times (need at least 2, one each)", b.label,
                                 b.frames.size(), b.exposure_seconds.size()));
  for (const ImageView& f : b.frames)
    if (f.empty() || f.channels != 3 || f.width != b.frames[0].width || f.height != b.frames[0].height)
      throw InputError(fmt::format("{}: frames must be RGB views of one size", b.label));
  check_response(resp, "response");
  if (!(o.black_threshold >= 0.0) || !(o.saturation_threshold <= 1.0) ||
      !(o.black_threshold < o.saturation_threshold))
    throw InputError(fmt::format("merge thresholds: need 0 <= black ({}) < saturation ({}) <= 1", o.black_threshold,
                                 o.saturation_threshold));
  if (o.threads < 0) throw InputError(fmt::format("merge threads {} is negative", o.threads));
  if (!b.codes.empty() && (b.codes.size() != b.frames.size() || std::count(b.codes.begin(), b.codes.end(), nullptr)))
    throw InputError(fmt::format("{}: 8-bit codes of {} frames for {} frames", b.label, b.codes.size(), b.frames.size()));
  const size_t nf = b.frames.size();
  const size_t npix = size_t(b.frames[0].width) * size_t(b.frames[0].height);
  if (!o.frame_masks.empty() && o.frame_masks.size() != nf)
    throw InputError(fmt::format("merge frame_masks: {} masks for {} frames", o.frame_masks.size(), nf));
  for (size_t k = 0; k < o.frame_masks.size(); ++k)
    if (o.frame_masks[k].size() != npix)
      throw InputError(fmt::format("merge frame_masks[{}]: {} bytes, need width*height = {}", k,
                                   o.frame_masks[k].size(), npix));
  const int L = resp.levels;
  Tables T;
  T.levels = L;
  T.scale = float(L - 1);
  const double lo = o.black_threshold, hi = o.saturation_threshold;
  const MergeWeights mw = merge_weights(resp, b.bit_depth, b.exposure_seconds, o);
  for (int c = 0; c < 3; ++c) {
    const std::vector<float>& g = resp.log_exposure[size_t(c)];
    T.w[size_t(c)] = mw.level[size_t(c)];
    T.wx[size_t(c)].resize(size_t(L));
    for (int l = 0; l < L; ++l)
      T.wx[size_t(c)][size_t(l)] = float(double(mw.level[size_t(c)][size_t(l)]) * std::exp(double(g[size_t(l)])));
  }
  for (int c = 0; c < 3; ++c) {
    T.w3.insert(T.w3.end(), T.w[size_t(c)].begin(), T.w[size_t(c)].end());
    T.wx3.insert(T.wx3.end(), T.wx[size_t(c)].begin(), T.wx[size_t(c)].end());
  }
  for (size_t k = 0; k < nf; ++k) {
    T.frame_w.push_back(mw.frame[k]);
    T.frame_wx.push_back(float(double(mw.frame[k]) / b.exposure_seconds[k]));
  }
  T.by_time.resize(nf);
  std::iota(T.by_time.begin(), T.by_time.end(), size_t(0));
  std::stable_sort(T.by_time.begin(), T.by_time.end(),
                   [&](size_t a, size_t c) { return b.exposure_seconds[a] < b.exposure_seconds[c]; });
  T.sat_level = int(std::ceil(hi * (L - 1) - 1e-9));
  T.black_level = int(std::floor(lo * (L - 1) + 1e-9));
  T.simd = o.simd;
  auto weightless = [&](int l) {
    for (int c = 0; c < 3; ++c)
      if (T.w[size_t(c)][size_t(l)] != 0.0f || T.wx[size_t(c)][size_t(l)] != 0.0f) return false;
    return true;
  };
  // 0 times a frame factor is +0 only when the factor is finite (an absurd exposure time can
  // make s_k / t_k overflow): otherwise no level is skipped.
  bool finite_factors = true;
  for (size_t k = 0; k < nf; ++k) finite_factors = finite_factors && std::isfinite(T.frame_w[k]) && std::isfinite(T.frame_wx[k]);
  T.zero_through = -1;
  while (finite_factors && T.zero_through + 1 < L && weightless(T.zero_through + 1)) ++T.zero_through;
  T.zero_from = L;
  while (finite_factors && T.zero_from - 1 > T.zero_through && weightless(T.zero_from - 1)) --T.zero_from;
  T.w_wx3.resize(T.w3.size());
  for (size_t i = 0; i < T.w3.size(); ++i) {
    const float pair[2] = {T.w3[i], T.wx3[i]};
    std::memcpy(&T.w_wx3[i], pair, sizeof pair);
  }
  for (int c = 0; c < 3; ++c)
    for (int l = 0; l < L; ++l) {  // as the scalar loop's bounds compute them
      const double e = std::exp(double(resp.log_exposure[size_t(c)][size_t(l)]));
      T.bound_short.push_back(float(e / b.exposure_seconds[T.by_time.front()]));
      T.bound_long.push_back(float(e / b.exposure_seconds[T.by_time.back()]));
    }
  auto same_channels = [&](const std::vector<float>& t) {  // bit for bit
    return std::memcmp(t.data(), t.data() + L, sizeof(float) * size_t(L)) == 0 &&
           std::memcmp(t.data(), t.data() + 2 * L, sizeof(float) * size_t(L)) == 0;
  };
  T.one_table = same_channels(T.w3) && same_channels(T.wx3);
  if (L == 256) {  // the VBMI kernel's tables: byte p of every float, per table and channel
    const std::vector<float>* tables[] = {&T.w3, &T.wx3, &T.bound_short, &T.bound_long};
    T.planes.resize(4 * 3 * 4 * 256);
    for (size_t t = 0; t < 4; ++t)
      for (size_t c = 0; c < 3; ++c)
        for (size_t l = 0; l < 256; ++l) {
          uint8_t bytes[4];
          std::memcpy(bytes, &(*tables[t])[c * 256 + l], 4);
          for (size_t p = 0; p < 4; ++p) T.planes[((t * 3 + c) * 4 + p) * 256 + l] = bytes[p];
        }
  }
  if (o.ignore_colour)
    for (int c = 0; c < 3; ++c) T.colour_level[size_t(c)] = int(std::lround((*o.ignore_colour)[size_t(c)] / 255.0 * (L - 1)));

  bool masked = false;
  T.keep.assign(nf, nullptr);
  T.valid.assign(nf, nullptr);
  T.valid_stride.assign(nf, 0);
  for (size_t k = 0; k < nf; ++k) {
    if (!o.frame_masks.empty()) T.keep[k] = o.frame_masks[k].data();
    T.valid[k] = b.frames[k].valid;
    T.valid_stride[k] = b.frames[k].stride / 3;
    masked = masked || T.keep[k] || T.valid[k];
  }

  RgbImage& out = *out_image;
  out.width = b.frames[0].width;
  out.height = b.frames[0].height;
  out.units = Units::Relative;
  out.rgb.resize(3 * size_t(out.width) * size_t(out.height));  // every value is written below
  if (o.ignore_colour || masked)
    out.valid.assign(npix, 1);
  else
    out.valid.clear();
  std::vector<uint8_t> flags;
  const bool want_flags = report && o.flag_image;
  if (want_flags) flags.assign(size_t(out.width) * size_t(out.height), 0);
  std::atomic<size_t> n_sat{0}, n_black{0}, n_ignored{0}, n_no_frame{0}, n_well{0};
  // The 8-bit codes are the levels themselves only at 256 levels; other responses read the floats.
  const bool codes = !b.codes.empty() && L == 256;
  auto run = [&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, out.height, 8), [&](const tbb::blocked_range<int>& r) {
      uint8_t* f = want_flags ? flags.data() : nullptr;
      const int y0 = r.begin(), y1 = r.end();
      auto rows = [&](auto with_codes) {
        constexpr bool kCodes = decltype(with_codes)::value;
        if (o.ignore_colour && masked)
          merge_rows<true, true, kCodes>(b, resp, T, y0, y1, out, f, n_sat, n_black, n_ignored, n_no_frame, n_well);
        else if (o.ignore_colour)
          merge_rows<true, false, kCodes>(b, resp, T, y0, y1, out, f, n_sat, n_black, n_ignored, n_no_frame, n_well);
        else if (masked)
          merge_rows<false, true, kCodes>(b, resp, T, y0, y1, out, f, n_sat, n_black, n_ignored, n_no_frame, n_well);
        else
          merge_rows<false, false, kCodes>(b, resp, T, y0, y1, out, f, n_sat, n_black, n_ignored, n_no_frame, n_well);
      };
      if (codes)
        rows(std::true_type{});
      else
        rows(std::false_type{});
    });
  };
  run_in_thread_arena(o.threads, run);
  if (n_well == 0)  // all black or all saturated: a uniform bound, not a measurement
    throw InputError(fmt::format("{}: no pixel is well exposed in any of the {} frames (every one is black or saturated "
                                 "in all of them)",
                                 b.label, nf));
  if (n_ignored == 0 && n_no_frame == 0) out.valid.clear();
  if (report) {
    report->saturated_everywhere = n_sat;
    report->black_everywhere = n_black;
    report->ignored = n_ignored;
    report->no_frame = n_no_frame;
    report->well_exposed = n_well;
    report->flags = std::move(flags);
    report->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
}

}  // namespace lp
