#include "core/openexr_cube.h"

#include <ImfEnvmap.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace lp {
namespace {

constexpr double kPi = 3.14159265358979323846;

Imath::Box2i cube_window(int face_size) { return {Imath::V2i(0, 0), Imath::V2i(face_size - 1, 6 * face_size - 1)}; }

// Where face position (i, j) lies in the stacked image: ImfEnvmap.h turns and flips each
// face, an affine map of (i, j) with integer steps, read once from OpenEXR's own
// pixelPosition instead of calling it for every tap.
struct FaceAffine {
  int x0, y0, xi, yi, xj, yj;  // image (x, y) = (x0 + i xi + j xj, y0 + i yi + j yj)
};

FaceAffine face_affine(int face_size, int face) {
  const Imath::Box2i dw = cube_window(face_size);
  const auto at = [&](float i, float j) {
    return Imf::CubeMap::pixelPosition(Imf::CubeMapFace(face), dw, Imath::V2f(i, j));
  };
  const Imath::V2f p00 = at(0, 0), p10 = at(1, 0), p01 = at(0, 1);
  const auto r = [](float v) { return int(std::lround(v)); };
  return {r(p00.x), r(p00.y), r(p10.x - p00.x), r(p10.y - p00.y), r(p01.x - p00.x), r(p01.y - p00.y)};
}

std::array<double, 3> bilinear(const std::vector<float>& rgb, int n, const FaceAffine& a, double x, double y) {
  x = std::clamp(x, 0.0, double(n - 1));
  y = std::clamp(y, 0.0, double(n - 1));
  const int i0 = std::min(int(x), n - 1), j0 = std::min(int(y), n - 1);
  const int i1 = std::min(i0 + 1, n - 1), j1 = std::min(j0 + 1, n - 1);
  const double fx = x - i0, fy = y - j0;
  const auto texel = [&](int i, int j) {
    const size_t px = size_t(a.x0 + i * a.xi + j * a.xj), py = size_t(a.y0 + i * a.yi + j * a.yj);
    return &rgb[3 * (py * size_t(n) + px)];
  };
  const float *t00 = texel(i0, j0), *t10 = texel(i1, j0), *t01 = texel(i0, j1), *t11 = texel(i1, j1);
  std::array<double, 3> out{};
  for (size_t c = 0; c < 3; ++c)
    out[c] = (1 - fy) * ((1 - fx) * t00[c] + fx * t10[c]) + fy * ((1 - fx) * t01[c] + fx * t11[c]);
  return out;
}

void check_cube(const std::vector<float>& rgb, int face_size) {
  if (face_size < 1 || rgb.size() != size_t(face_size) * size_t(6 * face_size) * 3)
    throw std::invalid_argument("OpenEXR cube map: buffer does not hold N x 6N RGB texels");
}

}  // namespace

Vec3 openexr_from_world(Vec3 d) { return {d.y, d.z, -d.x}; }
Vec3 world_from_openexr(Vec3 d) { return {-d.z, d.x, d.y}; }

std::array<double, 3> openexr_face_bilinear(const std::vector<float>& rgb, int face_size, int face, double x,
                                            double y) {
  return bilinear(rgb, face_size, face_affine(face_size, face), x, y);
}

std::array<double, 3> openexr_cube_bilinear(const std::vector<float>& rgb, int face_size, Vec3 exr_direction) {
  Imf::CubeMapFace face;
  Imath::V2f pif;
  Imf::CubeMap::faceAndPixelPosition(Imath::V3f(float(exr_direction.x), float(exr_direction.y), float(exr_direction.z)),
                                     cube_window(face_size), face, pif);
  return openexr_face_bilinear(rgb, face_size, int(face), pif.x, pif.y);
}

EnvMap openexr_cube_to_latlong(const std::vector<float>& rgb, int face_size) {
  check_cube(rgb, face_size);
  const int h = 2 * face_size, w = 2 * h;
  EnvMap map = make_latlong(w, h);
  map.valid.clear();
  FaceAffine affine[6];
  for (int f = 0; f < 6; ++f) affine[f] = face_affine(face_size, f);
  const Imath::Box2i dw = cube_window(face_size);
  constexpr int k = 2;  // sub-samples per pixel edge
  tbb::parallel_for(0, h, [&](int v) {
    const double c0 = std::cos(kPi * v / h), c1 = std::cos(kPi * (v + 1) / h);
    for (int u = 0; u < w; ++u) {
      double sum[3] = {0, 0, 0};
      for (int b = 0; b < k; ++b) {
        const double cos_t = c0 + (b + 0.5) / k * (c1 - c0), sin_t = std::sqrt(std::max(0.0, 1 - cos_t * cos_t));
        for (int a = 0; a < k; ++a) {
          const double phi = 2 * kPi * (u + (a + 0.5) / k) / w;
          const Vec3 e = openexr_from_world({sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t});
          Imf::CubeMapFace face;
          Imath::V2f pif;
          Imf::CubeMap::faceAndPixelPosition(Imath::V3f(float(e.x), float(e.y), float(e.z)), dw, face, pif);
          const auto s = bilinear(rgb, face_size, affine[int(face)], pif.x, pif.y);
          for (size_t c = 0; c < 3; ++c) sum[c] += s[c];
        }
      }
      float* p = map.pixel(size_t(v) * size_t(w) + size_t(u));
      for (size_t c = 0; c < 3; ++c) p[c] = float(sum[c] / (k * k));
    }
  });
  return map;
}

}  // namespace lp
