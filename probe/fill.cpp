#include "probe/fill.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "core/error.h"

namespace lp {
namespace {

// One pyramid level: premultiplied colour (3 per pixel) and weight in [0, 1].
struct Level {
  int w = 0, h = 0;
  std::vector<float> c;
  std::vector<float> wt;
};

// Normalise a pulled pixel so that its weight is at most 1 (Gortler's push-pull).
inline void clamp_weight(float* c, float* wt) {
  if (*wt > 1.0f) {
    const float s = 1.0f / *wt;
    c[0] *= s;
    c[1] *= s;
    c[2] *= s;
    *wt = 1.0f;
  }
}

// Push-pull on a W x H grid; x wraps around (azimuth), y is clamped.
void push_pull_grid(EnvMap& map) {
  std::vector<Level> levels(1);
  Level& l0 = levels[0];
  l0.w = map.width;
  l0.h = map.height;
  const size_t n = map.pixel_count();
  l0.c.resize(3 * n);
  l0.wt.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const float v = map.is_valid(i) ? 1.0f : 0.0f;
    l0.wt[i] = v;
    for (int k = 0; k < 3; ++k) l0.c[3 * i + k] = v ? map.rgb[3 * i + k] : 0.0f;
  }
  // Pull.
  while (levels.back().w > 1 || levels.back().h > 1) {
    const Level& f = levels.back();
    Level g;
    g.w = (f.w + 1) / 2;
    g.h = (f.h + 1) / 2;
    g.c.assign(3 * size_t(g.w) * g.h, 0.0f);
    g.wt.assign(size_t(g.w) * g.h, 0.0f);
    for (int y = 0; y < f.h; ++y)
      for (int x = 0; x < f.w; ++x) {
        const size_t fi = size_t(y) * f.w + x, gi = size_t(y / 2) * g.w + x / 2;
        g.wt[gi] += f.wt[fi];
        for (int k = 0; k < 3; ++k) g.c[3 * gi + k] += f.c[3 * fi + k];
      }
    for (size_t i = 0; i < g.wt.size(); ++i) clamp_weight(&g.c[3 * i], &g.wt[i]);
    levels.push_back(std::move(g));
  }
  if (levels.back().wt[0] <= 0.0f) throw InputError("cannot fill a map with no valid pixel");
  // Push: colour of the coarsest level, then each finer level = own + (1 - wt) * coarse.
  std::vector<float> coarse = levels.back().c;  // full colours (weight 1 at the top)
  {
    const float s = 1.0f / levels.back().wt[0];
    for (float& v : coarse) v *= s;
  }
  for (int li = int(levels.size()) - 2; li >= 0; --li) {
    const Level& f = levels[li];
    const Level& g = levels[li + 1];
    std::vector<float> full(3 * size_t(f.w) * f.h);
    for (int y = 0; y < f.h; ++y) {
      float cy = (y + 0.5f) * 0.5f - 0.5f;
      cy = std::clamp(cy, 0.0f, float(g.h - 1));
      const int y0 = std::min(int(cy), g.h - 1), y1 = std::min(y0 + 1, g.h - 1);
      const float fy = cy - y0;
      for (int x = 0; x < f.w; ++x) {
        const size_t fi = size_t(y) * f.w + x;
        float* out = &full[3 * fi];
        const float w = f.wt[fi];
        if (w >= 1.0f) {
          for (int k = 0; k < 3; ++k) out[k] = f.c[3 * fi + k];
          continue;
        }
        const float cx = (x + 0.5f) * 0.5f - 0.5f;
        const float xf = std::floor(cx);
        const float fx = cx - xf;
        const int x0 = ((int(xf) % g.w) + g.w) % g.w, x1 = (x0 + 1) % g.w;
        for (int k = 0; k < 3; ++k) {
          const float a = coarse[3 * (size_t(y0) * g.w + x0) + k], b = coarse[3 * (size_t(y0) * g.w + x1) + k];
          const float c = coarse[3 * (size_t(y1) * g.w + x0) + k], d = coarse[3 * (size_t(y1) * g.w + x1) + k];
          const float up = (1 - fy) * ((1 - fx) * a + fx * b) + fy * ((1 - fx) * c + fx * d);
          out[k] = f.c[3 * fi + k] + (1.0f - w) * up;
        }
      }
    }
    coarse.swap(full);
  }
  for (size_t i = 0; i < n; ++i)
    if (!map.is_valid(i))
      for (int k = 0; k < 3; ++k) map.rgb[3 * i + k] = coarse[3 * i + k];
}

// Push-pull on the HEALPix NESTED hierarchy: parent = index / 4; the 12 base pixels
// share the map's mean.
void push_pull_healpix(EnvMap& map) {
  std::vector<Level> levels(1);
  const size_t n = map.pixel_count();
  levels[0].w = int(n);
  levels[0].c.resize(3 * n);
  levels[0].wt.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const float v = map.is_valid(i) ? 1.0f : 0.0f;
    levels[0].wt[i] = v;
    for (int k = 0; k < 3; ++k) levels[0].c[3 * i + k] = v ? map.rgb[3 * i + k] : 0.0f;
  }
  while (levels.back().w > 12) {
    const Level& f = levels.back();
    Level g;
    g.w = f.w / 4;
    g.c.assign(3 * size_t(g.w), 0.0f);
    g.wt.assign(g.w, 0.0f);
    for (int i = 0; i < f.w; ++i) {
      g.wt[i / 4] += f.wt[i];
      for (int k = 0; k < 3; ++k) g.c[3 * (i / 4) + k] += f.c[3 * i + k];
    }
    for (int i = 0; i < g.w; ++i) clamp_weight(&g.c[3 * i], &g.wt[i]);
    levels.push_back(std::move(g));
  }
  const Level& base = levels.back();
  double sw = 0, sc[3] = {0, 0, 0};
  for (int i = 0; i < base.w; ++i) {
    sw += base.wt[i];
    for (int k = 0; k < 3; ++k) sc[k] += base.c[3 * i + k];
  }
  if (sw <= 0) throw InputError("cannot fill a map with no valid pixel");
  std::vector<float> coarse(3 * size_t(base.w));
  for (int i = 0; i < base.w; ++i)
    for (int k = 0; k < 3; ++k) coarse[3 * i + k] = base.c[3 * i + k] + (1.0f - base.wt[i]) * float(sc[k] / sw);
  for (int li = int(levels.size()) - 2; li >= 0; --li) {
    const Level& f = levels[li];
    std::vector<float> full(3 * size_t(f.w));
    for (int i = 0; i < f.w; ++i)
      for (int k = 0; k < 3; ++k) full[3 * i + k] = f.c[3 * i + k] + (1.0f - f.wt[i]) * coarse[3 * (i / 4) + k];
    coarse.swap(full);
  }
  for (size_t i = 0; i < n; ++i)
    if (!map.is_valid(i))
      for (int k = 0; k < 3; ++k) map.rgb[3 * i + k] = coarse[3 * i + k];
}

}  // namespace

void fill_invalid(EnvMap& map, const FillOptions& options, FillReport* report) {
  const size_t n = map.pixel_count();
  if (map.rgb.size() != 3 * n) throw InputError("fill: map holds " + std::to_string(map.rgb.size()) +
                                                " floats for " + std::to_string(n) + " RGB pixels");
  if (!map.valid.empty() && map.valid.size() != n)
    throw InputError("fill: mask holds " + std::to_string(map.valid.size()) + " entries for " +
                     std::to_string(n) + " pixels");
  size_t invalid = 0;
  if (!map.valid.empty())
    for (uint8_t v : map.valid) invalid += v == 0;
  if (invalid > 0) {
    switch (options.method) {
      case FillMethod::None:
        break;
      case FillMethod::Constant:
        for (size_t i = 0; i < n; ++i)
          if (!map.is_valid(i))
            for (int k = 0; k < 3; ++k) map.rgb[3 * i + k] = options.constant_rgb[k];
        break;
      case FillMethod::PushPull:
        if (map.layout == Layout::Healpix)
          push_pull_healpix(map);
        else
          push_pull_grid(map);
        break;
    }
  }
  if (report) {
    *report = FillReport{};
    report->filled_pixels = invalid;
    double filled = 0, total = 0, omega = 0;
    for (size_t i = 0; i < n; ++i) {
      const double sa = pixel_solid_angle(map, i);
      const float* p = map.pixel(i);
      const double y = std::max(0.0, double(luminance(p[0], p[1], p[2])));
      total += y * sa;
      if (!map.is_valid(i)) {
        omega += sa;
        filled += options.method == FillMethod::None ? 0.0 : y * sa;
      }
    }
    report->filled_solid_angle = omega;
    report->filled_power_share = total > 0 ? filled / total : 0.0;
  }
  if (!options.keep_mask && options.method != FillMethod::None) map.valid.clear();
}

}  // namespace lp
