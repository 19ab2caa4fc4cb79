// Remap engine: resample a camera image (RgbImage) through a per-output-pixel table of
// source coordinates. Every probe geometry (fisheye, mirror ball, ...) reduces to one
// RemapTable per camera model and output size; the table is built once and applied to
// every frame of a video.
//
// Coordinates: source pixel coordinates, x to the right, y downwards, pixel centres at
// +0.5 (pixel (i, j) covers [i, i+1) x [j, j+1)). NaN in either coordinate marks an
// output pixel with no source (outside the field of view): it is written black with
// valid = 0.
//
// Sampling: bilinear between the four nearest pixel centres, clamped at the border
// (a coordinate in [0, 0.5) or beyond the last centre uses the edge pixel), as
// cv::remap with BORDER_REPLICATE. The image covers [0, W] x [0, H]; coordinates
// outside it are invalid (off the sensor). When the source has a validity mask, an
// output pixel is valid only if every source pixel with non-zero weight is valid.
// Sources must be at least 2 x 2 pixels.
//
// Speed: apply_remap(src, RemapTable) compiles the table on every call. For video,
// compile once with compile_remap() and call apply_remap(src, compiled, &out), which
// reuses `out`'s storage. The compiled form stores per output pixel one int32 index of
// the top-left source pixel of the 2 x 2 footprint and the two bilinear fractions in
// 1/32768 px (8 bytes; the four weights are formed on the fly, which is cheaper than
// reading them; OpenCV's fixed-point maps quantise to 1/32 px); border clamping is folded into index and fractions so the inner loop has no
// branches but the validity test. Runs over rows in parallel with TBB. Without a source
// mask the compiled table runs a vector kernel (remap_kernel.h, RemapOptions::simd).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "core/envmap.h"
#include "core/image_io.h"
#include "core/image_view.h"

namespace lp {

struct RemapTable {
  int out_width = 0, out_height = 0;
  // Per output pixel (row-major, index = row * out_width + column): source pixel
  // coordinates, x right, y down, pixel centres at +0.5; NaN = invalid.
  std::vector<float> src_x, src_y;
};

struct RemapOptions {
  int threads = 0;  // 0 = TBB default (all cores); 1 = run on the calling thread
  // true (default): apply_remap(src, CompiledRemap, out) without a source validity mask runs
  // a vector kernel (probe/remap_kernel.h, Google Highway, the best of SSSE3/SSE4/AVX2/AVX-512
  // chosen at run time); false: the scalar loop, kept as its reference. The two give the same
  // image bit for bit (tests/probe/remap_kernel_test.cpp); a source mask runs the scalar loop.
  bool simd = true;
};

// Resample `src` through `table`. Output: table.out_width x table.out_height, units
// copied from the source, `valid` filled (empty when every output pixel is valid).
// Throws InputError when the table's arrays do not match its size or the source is empty.
RgbImage apply_remap(const RgbImage& src, const RemapTable& table, const RemapOptions& options = {});

// A table compiled for one source size: per output pixel the flat index of the
// top-left source pixel of the 2 x 2 bilinear footprint (-1 = invalid; the footprint
// always lies inside the image) and the fractions towards the right / lower neighbour:
// value = (1-fx)(1-fy) p[i] + fx(1-fy) p[i+1] + (1-fx)fy p[i+W] + fx fy p[i+W+1].
struct CompiledRemap {
  int src_width = 0, src_height = 0;
  int out_width = 0, out_height = 0;
  static constexpr float kFractionScale = 32768.0f;  // fractions in units of 1/32768 px
  struct Tap {
    int32_t index;    // source pixel index (row * src_width + column) or -1
    uint16_t fx, fy;  // fractions in [0, 1] times kFractionScale (exact at 0 and 1)
  };
  std::vector<Tap> taps;
  bool any_invalid = false;  // some tap is -1
};

CompiledRemap compile_remap(const RemapTable& table, int src_width, int src_height);

// Apply a compiled table. `out` is resized (its storage reused when already the right
// size); its units are the source's. Throws InputError when the source size differs from
// the compiled one.
void apply_remap(const RgbImage& src, const CompiledRemap& remap, RgbImage* out,
                 const RemapOptions& options = {});
// The same from a view (packed RGB rows, InputError otherwise); `out`'s units are left as
// they are.
void apply_remap(ImageView src, const CompiledRemap& remap, RgbImage* out, const RemapOptions& options = {});

// A projection of a unit world direction to source pixel coordinates in the convention
// above (pixel centres at +0.5: add 0.5 to OpenCV / mrcal pixels); nullopt where the lens
// sees nothing.
using RemapProjection = std::function<std::optional<std::array<double, 2>>(Vec3)>;
// The table that unwraps a src_width x src_height image into an environment map of
// `layout` (width, height as make_envmap): every map pixel's direction projected by
// `project`; directions that project off the image are invalid. Parallel over pixels.
RemapTable remap_table(Layout layout, int width, int height, int src_width, int src_height,
                       const RemapProjection& project);

}  // namespace lp
