#include "hdr/merge.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <numeric>

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include "core/error.h"

namespace lp {
namespace {

struct Tables {
  int levels = 0;
  float scale = 0.0f;                           // code value -> level (before + 0.5)
  std::array<std::vector<float>, 3> w, wx;      // hat(l), hat(l) * exp(g_c(l))
  std::vector<float> frame_w, frame_wx;         // per frame: s_k and s_k / t_k
  std::vector<size_t> by_time;                  // frame indices, shortest exposure first
  int sat_level = 0, black_level = 0;           // level >= sat_level: saturated; <= black_level: black
  std::array<int, 3> colour_level{-1, -1, -1};  // ignore_colour in levels, or -1
};

inline int level_of(float v, float scale, int levels) {
  const float s = v * scale + 0.5f;
  if (!(s > 0.0f)) return 0;  // also NaN
  const int l = int(s);
  return l < levels ? l : levels - 1;
}

template <bool kIgnore>
void merge_rows(const Bracket& b, const CameraResponse& resp, const Tables& T, int y0, int y1, RgbImage& out,
                uint8_t* flags, std::atomic<size_t>& n_sat, std::atomic<size_t>& n_black,
                std::atomic<size_t>& n_ignored) {
  const int W = b.width();
  const size_t nf = b.frames.size();
  const int L = T.levels;
  const float scale = T.scale;
  std::vector<float> sw(3 * size_t(W)), swx(3 * size_t(W));
  std::vector<uint8_t> used;  // kIgnore: frames that were not ignore_colour, per pixel
  if constexpr (kIgnore) used.resize(size_t(W));
  const float* w0 = T.w[0].data();
  const float* w1 = T.w[1].data();
  const float* w2 = T.w[2].data();
  const float* x0 = T.wx[0].data();
  const float* x1 = T.wx[1].data();
  const float* x2 = T.wx[2].data();
  size_t sat = 0, black = 0, ignored = 0;
  for (int y = y0; y < y1; ++y) {
    std::fill(sw.begin(), sw.end(), 0.0f);
    std::fill(swx.begin(), swx.end(), 0.0f);
    if constexpr (kIgnore) std::fill(used.begin(), used.end(), uint8_t(0));
    const size_t row = size_t(y) * size_t(W);
    for (size_t k = 0; k < nf; ++k) {
      const float* z = &b.frames[k].rgb[3 * row];
      const float fw = T.frame_w[k], fx = T.frame_wx[k];
      for (int x = 0; x < W; ++x) {
        const int l0 = level_of(z[3 * x], scale, L);
        const int l1 = level_of(z[3 * x + 1], scale, L);
        const int l2 = level_of(z[3 * x + 2], scale, L);
        if constexpr (kIgnore) {
          if (l0 == T.colour_level[0] && l1 == T.colour_level[1] && l2 == T.colour_level[2]) continue;
          used[size_t(x)] = 1;
        }
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
    float* o = &out.rgb[3 * row];
    for (int x = 0; x < W; ++x) {
      if constexpr (kIgnore) {
        if (!used[size_t(x)]) {
          out.valid[row + size_t(x)] = 0;
          o[3 * x] = o[3 * x + 1] = o[3 * x + 2] = 0.0f;
          ++ignored;
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
        // No usable frame for this channel (rare): classify and take a bound.
        bool all_sat = true, all_black = true;
        size_t best = nf;
        int best_d = 1 << 30;
        for (size_t k : T.by_time) {
          const float* p = &b.frames[k].rgb[3 * (row + size_t(x))];
          const int l = level_of(p[c], scale, L);
          if constexpr (kIgnore) {
            if (level_of(p[0], scale, L) == T.colour_level[0] && level_of(p[1], scale, L) == T.colour_level[1] &&
                level_of(p[2], scale, L) == T.colour_level[2])
              continue;
          }
          all_sat = all_sat && l >= T.sat_level;
          all_black = all_black && l <= T.black_level;
          const int d = std::abs(2 * l - (L - 1));
          if (d < best_d) best_d = d, best = k;
        }
        size_t pick = best;
        if (all_sat || all_black) {  // shortest exposure (lower bound) / longest (upper bound)
          for (size_t j = 0; j < nf; ++j) {
            const size_t k = all_sat ? T.by_time[j] : T.by_time[nf - 1 - j];
            const float* p = &b.frames[k].rgb[3 * (row + size_t(x))];
            if constexpr (kIgnore) {
              if (level_of(p[0], scale, L) == T.colour_level[0] && level_of(p[1], scale, L) == T.colour_level[1] &&
                  level_of(p[2], scale, L) == T.colour_level[2])
                continue;
            }
            pick = k;
            break;
          }
          flag |= all_sat ? kSaturatedEverywhere : kBlackEverywhere;
        }
        const int l = level_of(b.frames[pick].rgb[3 * (row + size_t(x)) + size_t(c)], scale, L);
        o[i] = float(std::exp(double(resp.log_exposure[size_t(c)][size_t(l)])) / b.exposure_seconds[pick]);
      }
      if (flag & kSaturatedEverywhere) ++sat;
      if (flag & kBlackEverywhere) ++black;
      if (flags) flags[row + size_t(x)] = flag;
    }
  }
  n_sat += sat;
  n_black += black;
  n_ignored += ignored;
}

}  // namespace

RgbImage merge_bracket(const Bracket& b, const CameraResponse& resp, const MergeOptions& o, MergeReport* report) {
  const auto start = std::chrono::steady_clock::now();
  check_bracket(b);
  check_response(resp, "response");
  if (!(o.black_threshold >= 0.0) || !(o.saturation_threshold <= 1.0) ||
      !(o.black_threshold < o.saturation_threshold))
    throw InputError(fmt::format("merge thresholds: need 0 <= black ({}) < saturation ({}) <= 1", o.black_threshold,
                                 o.saturation_threshold));
  if (o.threads < 0) throw InputError(fmt::format("merge threads {} is negative", o.threads));
  const size_t nf = b.frames.size();
  const int L = resp.levels;
  Tables T;
  T.levels = L;
  T.scale = float(L - 1);
  const double lo = o.black_threshold, hi = o.saturation_threshold;
  for (int c = 0; c < 3; ++c) {
    T.w[size_t(c)].resize(size_t(L));
    T.wx[size_t(c)].resize(size_t(L));
    for (int l = 0; l < L; ++l) {
      const double z = double(l) / double(L - 1);
      const double h = (z <= lo || z >= hi) ? 0.0 : 1.0 - std::abs(2.0 * (z - lo) / (hi - lo) - 1.0);
      T.w[size_t(c)][size_t(l)] = float(h);
      T.wx[size_t(c)][size_t(l)] = float(h * std::exp(double(resp.log_exposure[size_t(c)][size_t(l)])));
    }
  }
  // Exposure factors relative to the longest exposure keep every product in float range.
  const double t_max = *std::max_element(b.exposure_seconds.begin(), b.exposure_seconds.end());
  for (size_t k = 0; k < nf; ++k) {
    const double t = b.exposure_seconds[k];
    const double s = o.exposure_weighting ? t / t_max : 1.0;
    T.frame_w.push_back(float(s));
    T.frame_wx.push_back(float(s / t));
  }
  T.by_time.resize(nf);
  std::iota(T.by_time.begin(), T.by_time.end(), size_t(0));
  std::stable_sort(T.by_time.begin(), T.by_time.end(),
                   [&](size_t a, size_t c) { return b.exposure_seconds[a] < b.exposure_seconds[c]; });
  T.sat_level = int(std::ceil(hi * (L - 1) - 1e-9));
  T.black_level = int(std::floor(lo * (L - 1) + 1e-9));
  if (o.ignore_colour)
    for (int c = 0; c < 3; ++c) T.colour_level[size_t(c)] = int(std::lround((*o.ignore_colour)[size_t(c)] / 255.0 * (L - 1)));

  RgbImage out;
  out.width = b.width();
  out.height = b.height();
  out.units = Units::Relative;
  out.rgb.resize(3 * size_t(out.width) * size_t(out.height));
  if (o.ignore_colour) out.valid.assign(size_t(out.width) * size_t(out.height), 1);
  std::vector<uint8_t> flags;
  const bool want_flags = report && o.flag_image;
  if (want_flags) flags.assign(size_t(out.width) * size_t(out.height), 0);
  std::atomic<size_t> n_sat{0}, n_black{0}, n_ignored{0};
  auto run = [&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, out.height, 8), [&](const tbb::blocked_range<int>& r) {
      uint8_t* f = want_flags ? flags.data() : nullptr;
      if (o.ignore_colour)
        merge_rows<true>(b, resp, T, r.begin(), r.end(), out, f, n_sat, n_black, n_ignored);
      else
        merge_rows<false>(b, resp, T, r.begin(), r.end(), out, f, n_sat, n_black, n_ignored);
    });
  };
  if (o.threads > 0) {
    tbb::task_arena arena(o.threads);
    arena.execute(run);
  } else {
    run();
  }
  if (o.ignore_colour && n_ignored == 0) out.valid.clear();
  if (report) {
    report->saturated_everywhere = n_sat;
    report->black_everywhere = n_black;
    report->ignored = n_ignored;
    report->flags = std::move(flags);
    report->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  return out;
}

}  // namespace lp
