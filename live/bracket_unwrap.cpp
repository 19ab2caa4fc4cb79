#include "live/bracket_unwrap.h"

#include <cstring>
#include <string>

#include "core/error.h"

namespace lp {

BracketUnwrapPlan plan_bracket_unwrap(const CompiledRemap& remap) {
  BracketUnwrapPlan plan;
  plan.full = &remap;
  const size_t n = remap.taps.size();
  CompiledRemap& c = plan.compact;
  c.src_width = 2;
  c.src_height = int(2 * n);
  c.out_width = remap.out_width;
  c.out_height = remap.out_height;
  c.any_invalid = remap.any_invalid;
  c.taps.resize(n);
  for (size_t j = 0; j < n; ++j) {
    const CompiledRemap::Tap& t = remap.taps[j];
    c.taps[j] = {t.index < 0 ? -1 : int32_t(4 * j), t.fx, t.fy};
  }
  return plan;
}

namespace {

// The 2 x 2 footprint of every tap of `remap` (k values per source pixel, rows `width`
// pixels long) into dst[4 k j, 4 k (j + 1)): p[i], p[i + 1], p[i + W], p[i + W + 1].
// Invalid taps leave their footprint as it is.
template <class T>
void gather_footprints(const T* src, size_t width, size_t k, const CompiledRemap& remap, T* dst) {
  for (size_t j = 0; j < remap.taps.size(); ++j) {
    const int32_t index = remap.taps[j].index;
    if (index < 0) continue;
    const size_t i = size_t(index);
    std::memcpy(dst + 4 * k * j, src + k * i, 2 * k * sizeof(T));
    std::memcpy(dst + 4 * k * j + 2 * k, src + k * (i + width), 2 * k * sizeof(T));
  }
}

// Frame -> its footprints, 2 pixels per row, 2 rows per output pixel.
RgbImage gather(const RgbImage& frame, const CompiledRemap& remap) {
  const size_t n = remap.taps.size();
  RgbImage g;
  g.width = 2;
  g.height = int(2 * n);
  g.units = frame.units;
  g.rgb.assign(12 * n, 0.0f);
  const size_t W = size_t(frame.width);
  gather_footprints(frame.rgb.data(), W, 3, remap, g.rgb.data());
  if (!frame.valid.empty()) {
    g.valid.assign(4 * n, 0);
    gather_footprints(frame.valid.data(), W, 1, remap, g.valid.data());
  }
  return g;
}

}  // namespace

RgbImage fuse_and_unwrap(const Bracket& bracket, const CameraResponse& response, const MergeOptions& merge,
                         const BracketUnwrapPlan& plan, const RemapOptions& remap_options) {
  if (!plan.full) throw InputError("fuse_and_unwrap: the plan has no remap");
  const CompiledRemap& full = *plan.full;
  Bracket compact;
  compact.exposure_seconds = bracket.exposure_seconds;
  compact.bit_depth = bracket.bit_depth;
  compact.linear = bracket.linear;
  for (size_t k = 0; k < bracket.frames.size(); ++k) {
    const RgbImage& f = bracket.frames[k];
    if (f.width != full.src_width || f.height != full.src_height)
      throw InputError("bracket frame " + std::to_string(k + 1) + " is " + std::to_string(f.width) + "x" +
                       std::to_string(f.height) + ", the unwrap expects " + std::to_string(full.src_width) + "x" +
                       std::to_string(full.src_height));
    compact.frames.push_back(gather(f, full));
  }
  MergeOptions options = merge;
  // Masks are per pixel of the frames: gather them like the pixels.
  for (auto& mask : options.frame_masks) {
    std::vector<uint8_t> g(4 * full.taps.size(), 0);
    gather_footprints(mask.data(), size_t(full.src_width), 1, full, g.data());
    mask = std::move(g);
  }
  const RgbImage merged = merge_bracket(compact, response, options);
  RgbImage out;
  apply_remap(merged, plan.compact, &out, remap_options);
  return out;
}

}  // namespace lp
