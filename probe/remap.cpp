#include "probe/remap.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"
#include "core/thread_arena.h"
#include "probe/remap_kernel.h"

namespace lp {
namespace {

// One coordinate (pixel-centre convention) -> top-left index along the axis and the
// fraction towards the next one, clamped so that i0 + 1 < n. False when off the image.
inline bool axis_tap(float x, int n, int* i0, float* f) {
  if (!(x >= 0.0f && x <= float(n))) return false;  // also rejects NaN
  float u = x - 0.5f;
  if (u <= 0.0f) {
    *i0 = 0;
    *f = 0.0f;
    return true;
  }
  if (u >= float(n - 1)) {
    *i0 = n - 2;
    *f = 1.0f;
    return true;
  }
  int i = int(u);  // u > 0: truncation is floor
  if (i > n - 2) i = n - 2;
  *i0 = i;
  *f = u - float(i);
  return true;
}

template <typename F>
void run_rows(int rows, const RemapOptions& options, F&& body) {
  auto loop = [&] {
    tbb::parallel_for(tbb::blocked_range<int>(0, rows, 8),
                      [&](const tbb::blocked_range<int>& r) { body(r.begin(), r.end()); });
  };
  if (options.threads == 1) {
    body(0, rows);
  } else {
    run_in_thread_arena(options.threads, loop);
  }
}

}  // namespace

CompiledRemap compile_remap(const RemapTable& table, int src_width, int src_height) {
  if (table.out_width <= 0 || table.out_height <= 0)
    throw InputError("remap table has size " + std::to_string(table.out_width) + "x" +
                     std::to_string(table.out_height));
  const size_t n = size_t(table.out_width) * size_t(table.out_height);
  if (table.src_x.size() != n || table.src_y.size() != n)
    throw InputError("remap table holds " + std::to_string(table.src_x.size()) + "/" +
                     std::to_string(table.src_y.size()) + " coordinates for " + std::to_string(n) +
                     " output pixels");
  if (src_width < 2 || src_height < 2)
    throw InputError("remap source is " + std::to_string(src_width) + "x" + std::to_string(src_height) +
                     ", needs at least 2x2 pixels");
  if (size_t(src_width) * size_t(src_height) > size_t(INT32_MAX))
    throw InputError("remap source is too large for 32-bit indices");
  CompiledRemap c;
  c.src_width = src_width;
  c.src_height = src_height;
  c.out_width = table.out_width;
  c.out_height = table.out_height;
  c.taps.resize(n);
  bool any_invalid = false;
  for (size_t i = 0; i < n; ++i) {
    int ix, iy;
    float fx, fy;
    CompiledRemap::Tap& t = c.taps[i];
    if (axis_tap(table.src_x[i], src_width, &ix, &fx) && axis_tap(table.src_y[i], src_height, &iy, &fy)) {
      t.index = int32_t(iy * src_width + ix);
      t.fx = uint16_t(std::lround(fx * CompiledRemap::kFractionScale));
      t.fy = uint16_t(std::lround(fy * CompiledRemap::kFractionScale));
    } else {
      t.index = -1;
      t.fx = t.fy = 0;
      any_invalid = true;
    }
  }
  c.any_invalid = any_invalid;
  return c;
}

void apply_remap(ImageView src, const CompiledRemap& remap, RgbImage* out, const RemapOptions& options) {
  if (src.width != remap.src_width || src.height != remap.src_height)
    throw InputError("remap compiled for a " + std::to_string(remap.src_width) + "x" +
                     std::to_string(remap.src_height) + " source, image is " + std::to_string(src.width) + "x" +
                     std::to_string(src.height));
  if (!src.data || src.channels != 3 || !src.packed())
    throw InputError("remap source is not packed RGB (" + std::to_string(src.channels) + " channels, rows " +
                     std::to_string(src.stride) + " floats apart)");
  const bool src_mask = src.valid != nullptr;
  const size_t n = size_t(remap.out_width) * size_t(remap.out_height);
  out->width = remap.out_width;
  out->height = remap.out_height;
  out->rgb.resize(3 * n);
  const bool want_mask = remap.any_invalid || src_mask;
  if (want_mask)
    out->valid.resize(n);
  else
    out->valid.clear();

  const float* s = src.data;
  const uint8_t* sm = src.valid;
  const ptrdiff_t W = src.width;
  const ptrdiff_t row3 = 3 * W;
  const CompiledRemap::Tap* taps = remap.taps.data();
  float* o = out->rgb.data();
  uint8_t* om = want_mask ? out->valid.data() : nullptr;
  const int ow = remap.out_width;

  // The vector kernel (remap_kernel.h) without a source mask; the scalar loop below for the
  // rest, and as its reference. One thread, 1280x960 -> 1024x512 (bench probe/unwrap_*, AMD
  // EPYC, best of 9): scalar loop 2.96 ms; kernel AVX-512 1.67, AVX2 1.58, SSE4 1.56 ms.
  const bool vector = options.simd && !sm;

  run_rows(remap.out_height, options, [&](int r0, int r1) {
    const size_t begin = size_t(r0) * size_t(ow), end = size_t(r1) * size_t(ow);
    size_t i = begin;
    if (vector) {
      i += detail::remap_run_simd(s, W, taps + begin, end - begin, o + 3 * begin);
      if (om)
        for (size_t j = begin; j < i; ++j) om[j] = taps[j].index >= 0;
    }
    for (; i < end; ++i) {
      const CompiledRemap::Tap t = taps[i];
      float* d = o + 3 * i;
      if (t.index < 0) {
        d[0] = d[1] = d[2] = 0.0f;
        if (om) om[i] = 0;
        continue;
      }
      const float* p = s + 3 * ptrdiff_t(t.index);
      const float fx = float(t.fx) * (1.0f / CompiledRemap::kFractionScale);
      const float fy = float(t.fy) * (1.0f / CompiledRemap::kFractionScale);
      const float gx = 1.0f - fx, gy = 1.0f - fy;
      const float w00 = gx * gy, w10 = fx * gy, w01 = gx * fy, w11 = fx * fy;
      const float* q = p + row3;
      d[0] = w00 * p[0] + w10 * p[3] + w01 * q[0] + w11 * q[3];
      d[1] = w00 * p[1] + w10 * p[4] + w01 * q[1] + w11 * q[4];
      d[2] = w00 * p[2] + w10 * p[5] + w01 * q[2] + w11 * q[5];
      if (om) {
        uint8_t v = 1;
        if (sm) {
          const uint8_t* m = sm + t.index;
          v = (w00 <= 0.0f || m[0]) && (w10 <= 0.0f || m[1]) && (w01 <= 0.0f || m[W]) && (w11 <= 0.0f || m[W + 1]);
          if (!v) d[0] = d[1] = d[2] = 0.0f;
        }
        om[i] = v;
      }
    }
  });
  if (want_mask && !remap.any_invalid) {
    // The source mask may still have left every output pixel valid: keep "empty = all valid".
    bool all = true;
    for (uint8_t v : out->valid)
      if (!v) {
        all = false;
        break;
      }
    if (all) out->valid.clear();
  }
}

RemapTable remap_table(Layout layout, int width, int height, int src_width, int src_height,
                       const RemapProjection& project) {
  const EnvMap shape = make_envmap(layout, width, height);
  RemapTable t;
  t.out_width = shape.width;
  t.out_height = shape.height;
  const size_t n = shape.pixel_count();
  t.src_x.resize(n);
  t.src_y.resize(n);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const auto p = project(pixel_direction(shape, i));
      const double x = p ? (*p)[0] : -1, y = p ? (*p)[1] : -1;
      if (p && x >= 0 && x <= src_width && y >= 0 && y <= src_height) {
        t.src_x[i] = float(x);
        t.src_y[i] = float(y);
      } else {
        t.src_x[i] = t.src_y[i] = nan;
      }
    }
  });
  return t;
}

void apply_remap(const RgbImage& src, const CompiledRemap& remap, RgbImage* out, const RemapOptions& options) {
  if (src.width == remap.src_width && src.height == remap.src_height) {  // else the view's size error
    if (src.rgb.size() != size_t(src.width) * size_t(src.height) * 3)
      throw InputError("remap source holds " + std::to_string(src.rgb.size()) + " floats for " +
                       std::to_string(src.width) + "x" + std::to_string(src.height) + " RGB pixels");
    if (!src.valid.empty() && src.valid.size() != size_t(src.width) * size_t(src.height))
      throw InputError("remap source mask has the wrong size");
  }
  apply_remap(image_view(src), remap, out, options);
  out->units = src.units;
}

RgbImage apply_remap(const RgbImage& src, const RemapTable& table, const RemapOptions& options) {
  if (src.width <= 0 || src.height <= 0) throw InputError("remap source image is empty");
  RgbImage out;
  apply_remap(src, compile_remap(table, src.width, src.height), &out, options);
  return out;
}

}  // namespace lp
