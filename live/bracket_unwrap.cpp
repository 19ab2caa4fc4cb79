#include "live/bracket_unwrap.h"

#include <algorithm>
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
    if (t.index >= 0) plan.gather_order.push_back(uint32_t(j));
  }
  std::stable_sort(plan.gather_order.begin(), plan.gather_order.end(),
                   [&](uint32_t a, uint32_t b) { return remap.taps[a].index < remap.taps[b].index; });
  return plan;
}

namespace {

// The 2 x 2 footprint of every tap j of `remap` (k values per source pixel, rows `width`
// pixels long) into dst[4 k j, 4 k (j + 1)): p[i], p[i + 1], p[i + W], p[i + W + 1], the
// valid taps in the plan's gather order; an invalid tap's footprint is zeroed (the remap never
// reads it: this only keeps a reused buffer free of an older bracket's values). k is a template
// constant so that the two copies per tap are inlined moves rather than memcpy calls.
template <size_t k, class T>
void gather_footprints(const T* src, size_t width, const BracketUnwrapPlan& plan, T* dst) {
  const CompiledRemap& remap = *plan.full;
  // The footprints of the tap 24 ahead are requested early (a compiler builtin, a no-op
  // where the CPU has no prefetch): the frames are cache-cold and the two rows of a
  // footprint are two interleaved streams. Fuse+unwrap CPU time 2.75 -> 2.33 ms (median of 4
  // interleaved pairs, load ~5).
  const size_t count = plan.gather_order.size();
  constexpr size_t kAhead = 24;
  for (size_t o = 0; o < count; ++o) {
    const uint32_t j = plan.gather_order[o];
    if (o + kAhead < count) {
      const size_t a = size_t(remap.taps[plan.gather_order[o + kAhead]].index);
      __builtin_prefetch(src + k * a);
      __builtin_prefetch(src + k * (a + width));
    }
    const size_t i = size_t(remap.taps[j].index);
    std::memcpy(dst + 4 * k * j, src + k * i, 2 * k * sizeof(T));
    std::memcpy(dst + 4 * k * j + 2 * k, src + k * (i + width), 2 * k * sizeof(T));
  }
  if (remap.any_invalid)
    for (size_t j = 0; j < remap.taps.size(); ++j)
      if (remap.taps[j].index < 0) std::fill(dst + 4 * k * j, dst + 4 * k * (j + 1), T(0));
}

// The merge is per pixel, so the footprints' layout is free: it sees them as rows of
// 4 x the map width pixels (the footprints of whole map rows), wide enough for its vector kernel,
// which the remap's 2-pixel rows were not (2 pixels a row ran the scalar loop: 47 % of
// fuse_and_unwrap's time). The pixels are the same, in the same order.
struct MergeShape {
  int width, height;
};
MergeShape merge_shape(const CompiledRemap& remap) {
  const size_t n = remap.taps.size();
  if (remap.out_width > 0 && n % size_t(remap.out_width) == 0) return {4 * remap.out_width, int(n) / remap.out_width};
  return {2, int(2 * n)};
}

// Frame -> its footprints, as the merge sees them (merge_shape), into g (its storage reused).
void gather(const RgbImage& frame, const BracketUnwrapPlan& plan, RgbImage& g) {
  const CompiledRemap& remap = *plan.full;
  const size_t n = remap.taps.size();
  const MergeShape shape = merge_shape(remap);
  g.width = shape.width;
  g.height = shape.height;
  g.units = frame.units;
  g.rgb.resize(12 * n);  // every value is written below
  const size_t W = size_t(frame.width);
  gather_footprints<3>(frame.rgb.data(), W, plan, g.rgb.data());
  if (!frame.valid.empty()) {
    g.valid.resize(4 * n);
    gather_footprints<1>(frame.valid.data(), W, plan, g.valid.data());
  } else {
    g.valid.clear();
  }
}

}  // namespace

RgbImage fuse_and_unwrap(const Bracket& bracket, const CameraResponse& response, const MergeOptions& merge,
                         const BracketUnwrapPlan& plan, const RemapOptions& remap_options,
                         FuseUnwrapWorkspace* workspace) {
  if (!plan.full) throw InputError("fuse_and_unwrap: the plan has no remap");
  const CompiledRemap& full = *plan.full;
  check_bracket(bracket);  // before the gather reads the frames (and their masks) by the remap's indices
  FuseUnwrapWorkspace local;
  FuseUnwrapWorkspace& ws = workspace ? *workspace : local;
  ws.footprints.resize(bracket.frames.size());
  BracketView compact;
  compact.exposure_seconds = bracket.exposure_seconds;
  compact.bit_depth = bracket.bit_depth;
  if (!bracket.paths.empty()) compact.label = bracket.paths.front() + " .. " + bracket.paths.back();
  for (size_t k = 0; k < bracket.frames.size(); ++k) {
    const RgbImage& f = bracket.frames[k];
    if (f.width != full.src_width || f.height != full.src_height)
      throw InputError("bracket frame " + std::to_string(k + 1) + " is " + std::to_string(f.width) + "x" +
                       std::to_string(f.height) + ", the unwrap expects " + std::to_string(full.src_width) + "x" +
                       std::to_string(full.src_height));
    if (!f.valid.empty() && f.valid.size() != size_t(f.width) * size_t(f.height))
      throw InputError("bracket frame " + std::to_string(k + 1) + ": valid mask of " + std::to_string(f.valid.size()) +
                       " bytes, need width*height = " + std::to_string(size_t(f.width) * size_t(f.height)));
    gather(f, plan, ws.footprints[k]);
    compact.frames.push_back(image_view(ws.footprints[k]));
  }
  MergeOptions options = merge;
  // Masks are per pixel of the frames: gather them like the pixels.
  for (auto& mask : options.frame_masks) {
    if (mask.size() != size_t(full.src_width) * size_t(full.src_height))
      throw InputError("merge frame_masks: " + std::to_string(mask.size()) + " bytes, need width*height = " +
                       std::to_string(size_t(full.src_width) * size_t(full.src_height)));
    std::vector<uint8_t> g(4 * full.taps.size(), 0);
    gather_footprints<1>(mask.data(), size_t(full.src_width), plan, g.data());
    mask = std::move(g);
  }
  merge_bracket(compact, response, options, &ws.merged);
  ws.merged.width = plan.compact.src_width;  // the same pixels, as the remap reads them
  ws.merged.height = plan.compact.src_height;
  RgbImage out;
  apply_remap(ws.merged, plan.compact, &out, remap_options);
  return out;
}

}  // namespace lp
