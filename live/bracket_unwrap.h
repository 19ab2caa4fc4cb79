// Fusing a bracket and unwrapping it in one step, merging only the sensor pixels the
// unwrap reads: the result is the same as apply_remap(merge_bracket(bracket), remap) (each
// source pixel merged on its own, then interpolated), but a 360x90 map from 1280x960
// frames merges 4 x 32 400 gathered pixels instead of 1.2 million, ~10x less work.
// (Unwrapping each exposure first and merging the interpolated codes is cheaper still,
// but wrong where a footprint straddles the sun's edge: no exposure sees that blend
// unclipped, so the merge falls back to a saturation bound.)
#pragma once

#include <cstdint>
#include <vector>

#include "hdr/bracket.h"
#include "hdr/merge.h"
#include "hdr/response.h"
#include "probe/remap.h"

namespace lp {

// The gather plan of one compiled remap: per output pixel its 2 x 2 source footprint,
// laid out as a 2-wide image (output j's footprint at rows 2j, 2j + 1), and the remap of
// that compact image to the output.
struct BracketUnwrapPlan {
  const CompiledRemap* full = nullptr;  // the remap of the camera frames (not owned)
  CompiledRemap compact;
  // The valid taps of `full` in the order of their source pixels: the gather reads the
  // cache-cold frames front to back, which the hardware prefetches, instead of in map order,
  // which jumps around the fisheye circle.
  std::vector<uint32_t> gather_order;
};
BracketUnwrapPlan plan_bracket_unwrap(const CompiledRemap& remap);

// Buffers of fuse_and_unwrap kept from one bracket to the next, as a stream keeps them: the
// gathered footprints and the merged image are then neither allocated nor zero-filled per
// bracket (6 MB at 1280x960 -> 360x90). One workspace serves one thread at a time.
struct FuseUnwrapWorkspace {
  std::vector<RgbImage> footprints;  // per frame
  RgbImage merged;
};

// Every frame must have the remap's source size (InputError otherwise). Units and the
// valid mask are those of apply_remap(merge_bracket(...)). workspace: optional, see above.
RgbImage fuse_and_unwrap(const Bracket& bracket, const CameraResponse& response, const MergeOptions& merge,
                         const BracketUnwrapPlan& plan, const RemapOptions& remap_options = {},
                         FuseUnwrapWorkspace* workspace = nullptr);

}  // namespace lp
