#include "probe/ball_register.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/error.h"

namespace lp {

BallInImage registered_ball(int output_size, double margin) {
  if (output_size < 2) throw InputError("register balls: output size must be at least 2");
  if (!(margin > 0) || !std::isfinite(margin)) throw InputError("register balls: margin must be positive");
  return {0.5 * output_size, 0.5 * output_size, output_size / (2 * margin)};
}

std::vector<RgbImage> register_balls(const std::vector<RgbImage>& frames, const std::vector<BallInImage>& balls,
                                     int output_size, double margin) {
  const BallInImage dst = registered_ball(output_size, margin);
  if (frames.size() != balls.size())
    throw InputError("register balls: " + std::to_string(frames.size()) + " frames but " +
                     std::to_string(balls.size()) + " balls");
  std::vector<RgbImage> out;
  out.reserve(frames.size());
  for (size_t f = 0; f < frames.size(); ++f) {
    const RgbImage& src = frames[f];
    const BallInImage& b = balls[f];
    const int w = src.width, h = src.height;
    if (w < 1 || h < 1 || src.rgb.size() != size_t(3) * w * h)
      throw InputError("register balls: frame " + std::to_string(f) + " is empty");
    if (!src.valid.empty() && src.valid.size() != size_t(w) * h)
      throw InputError("register balls: frame " + std::to_string(f) + " has a mask of the wrong size");
    if (!(b.radius_px > 0) || !std::isfinite(b.cx) || !std::isfinite(b.cy) || !std::isfinite(b.radius_px))
      throw InputError("register balls: ball " + std::to_string(f) + " needs a finite centre and positive radius");
    RgbImage img;
    img.width = img.height = output_size;
    img.units = src.units;
    img.code_bits = src.code_bits;
    img.rgb.assign(size_t(3) * output_size * output_size, 0.f);
    img.valid.assign(size_t(output_size) * output_size, 0);
    const double k = b.radius_px / dst.radius_px;
    for (int v = 0; v < output_size; ++v)
      for (int u = 0; u < output_size; ++u) {
        const double x = b.cx + (u + 0.5 - dst.cx) * k, y = b.cy + (v + 0.5 - dst.cy) * k;
        if (!(x >= 0 && y >= 0 && x <= w && y <= h)) continue;
        // Bilinear between pixel centres, edge pixels replicated within the outer half pixel.
        const double fx = x - 0.5, fy = y - 0.5;
        const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
        const double ax = fx - x0, ay = fy - y0;
        double acc[3] = {0, 0, 0};
        bool ok = true;
        for (int dy = 0; dy < 2 && ok; ++dy)
          for (int dx = 0; dx < 2; ++dx) {
            const double wgt = (dx ? ax : 1 - ax) * (dy ? ay : 1 - ay);
            if (wgt <= 0) continue;
            const int xx = std::clamp(x0 + dx, 0, w - 1), yy = std::clamp(y0 + dy, 0, h - 1);
            const size_t j = size_t(yy) * w + xx;
            if (!src.valid.empty() && !src.valid[j]) {
              ok = false;
              break;
            }
            for (int c = 0; c < 3; ++c) acc[c] += wgt * src.rgb[3 * j + c];
          }
        if (!ok) continue;
        const size_t i = size_t(v) * output_size + u;
        img.valid[i] = 1;
        for (int c = 0; c < 3; ++c) img.rgb[3 * i + c] = float(acc[c]);
      }
    out.push_back(std::move(img));
  }
  return out;
}

}  // namespace lp
