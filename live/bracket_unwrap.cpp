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

// Frame -> its footprints, 2 pixels per row, 2 rows per output pixel.
RgbImage gather(const RgbImage& frame, const CompiledRemap& remap) {
  const size_t n = remap.taps.size();
  RgbImage g;
  g.width = 2;
  g.height = int(2 * n);
  g.units = frame.units;
  g.rgb.assign(12 * n, 0.0f);
  const bool masked = !frame.valid.empty();
  if (masked) g.valid.assign(4 * n, 0);
  const size_t W = size_t(frame.width);
  const float* s = frame.rgb.data();
  for (size_t j = 0; j < n; ++j) {
    const int32_t index = remap.taps[j].index;
    if (index < 0) continue;
    const size_t i = size_t(index);
    float* d = g.rgb.data() + 12 * j;
    std::memcpy(d, s + 3 * i, 6 * sizeof(float));            // p[i], p[i + 1]
    std::memcpy(d + 6, s + 3 * (i + W), 6 * sizeof(float));  // p[i + W], p[i + W + 1]
    if (masked) {
      uint8_t* m = g.valid.data() + 4 * j;
      m[0] = frame.valid[i], m[1] = frame.valid[i + 1], m[2] = frame.valid[i + W], m[3] = frame.valid[i + W + 1];
    }
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
    const size_t W = size_t(full.src_width);
    for (size_t j = 0; j < full.taps.size(); ++j) {
      const int32_t index = full.taps[j].index;
      if (index < 0) continue;
      const size_t i = size_t(index);
      g[4 * j] = mask[i], g[4 * j + 1] = mask[i + 1], g[4 * j + 2] = mask[i + W], g[4 * j + 3] = mask[i + W + 1];
    }
    mask = std::move(g);
  }
  const RgbImage merged = merge_bracket(compact, response, options);
  RgbImage out;
  apply_remap(merged, plan.compact, &out, remap_options);
  return out;
}

}  // namespace lp
