#include "render/prefilter.h"

#include <ImfChannelList.h>
#include <ImfCompression.h>
#include <ImfTileDescription.h>
#include <ImfEnvmap.h>
#include <ImfEnvmapAttribute.h>
#include <ImfStandardAttributes.h>
#include <ImfFloatVectorAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfStdIO.h>
#include <ImfStringAttribute.h>
#include <ImfTiledOutputFile.h>
#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/openexr_cube.h"
#include "sampling/halton.h"

namespace lp {
namespace {

constexpr double kPi = 3.14159265358979323846;

Imath::Box2i cube_window(int face_size) { return {Imath::V2i(0, 0), Imath::V2i(face_size - 1, 6 * face_size - 1)}; }

// GGX normal distribution, alpha = r^2.
double ggx_d(double n_dot_h, double alpha) {
  const double a2 = alpha * alpha, t = n_dot_h * n_dot_h * (a2 - 1) + 1;
  return a2 / (kPi * t * t);
}

// The GGX half vector of sample (u1, u2) in the frame with n = +z.
Vec3 ggx_half_vector(double u1, double u2, double alpha) {
  const double cos_t = std::sqrt((1 - u1) / (1 + (alpha * alpha - 1) * u1));
  const double sin_t = std::sqrt(std::max(0.0, 1 - cos_t * cos_t)), phi = 2 * kPi * u2;
  return {sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
}

// Lookups in a cube level: core/openexr_cube.h's, shared with the reader of OpenEXR cube maps.
std::array<double, 3> face_bilinear(const CubeLevel& c, int face, double x, double y) {
  return openexr_face_bilinear(c.rgb, c.face_size, face, x, y);
}
std::array<double, 3> cube_bilinear(const CubeLevel& c, Vec3 exr_direction) {
  return openexr_cube_bilinear(c.rgb, c.face_size, exr_direction);
}

// A cube (OpenEXR layout) and its box-filtered mips: each level is summed over the mip of
// its own face size.
struct CubePyramid {
  std::vector<CubeLevel> levels;
};

// Calls body(pixel, face, i, j, direction) for every texel of a cube image with faces of
// `face_size`: (i, j) its position in the face, `pixel` its index in the stacked image, the
// direction in the OpenEXR frame, all as ImfCubeMap.h maps them (faces are stored rotated
// and flipped, so the face position is not the image position).
template <typename F>
void for_each_texel(int face_size, F body) {
  const Imath::Box2i dw = cube_window(face_size);
  tbb::parallel_for(0, 6 * face_size, [&](int row) {
    const auto face = Imf::CubeMapFace(row / face_size);
    const float j = float(row % face_size);
    for (int i = 0; i < face_size; ++i) {
      const Imath::V2f p = Imf::CubeMap::pixelPosition(face, dw, Imath::V2f(float(i), j));
      const Imath::V3f d = Imf::CubeMap::direction(face, dw, Imath::V2f(float(i), j));
      body(size_t(std::lround(p.y)) * size_t(face_size) + size_t(std::lround(p.x)), int(face), float(i), j,
           Vec3{d.x, d.y, d.z});
    }
  });
}

// The next mip: each texel the mean of four bilinear taps of this level half a texel around
// its own position. OpenEXR puts a face's outer texels on the cube's edges, so texel m of
// the smaller face is not the centre of texels 2m, 2m + 1 of this one: a plain 2 x 2 box
// would shift every mip towards the face centres (a 6 % error at r = 1, tested).
CubeLevel downsample(const CubeLevel& c) {
  CubeLevel d;
  d.face_size = c.face_size / 2;
  d.rgb.assign(size_t(d.face_size) * size_t(6 * d.face_size) * 3, 0.0f);
  const double scale = d.face_size > 1 ? double(c.face_size - 1) / (d.face_size - 1) : 0;
  for_each_texel(d.face_size, [&](size_t pixel, int face, float i, float j, Vec3) {
    const double x = d.face_size > 1 ? i * scale : 0.5 * (c.face_size - 1), y = d.face_size > 1 ? j * scale : x;
    double sum[3] = {0, 0, 0};
    for (double dx : {-0.5, 0.5})
      for (double dy : {-0.5, 0.5}) {
        const auto v = face_bilinear(c, face, x + dx, y + dy);
        for (int ch = 0; ch < 3; ++ch) sum[ch] += v[size_t(ch)];
      }
    for (int ch = 0; ch < 3; ++ch) d.rgb[3 * pixel + size_t(ch)] = float(sum[ch] / 4);
  });
  return d;
}

// Level 0: every map pixel (split into sub-pixels on a latlong map where the cube is finer)
// spread into the texel it falls in, weighted by its solid angle, so the cube holds the map's
// power; a texel no pixel fell in (cube finer than the map) takes the nearest pixel.
// Nearest-pixel lookups alone lost or doubled small bright windows near the poles (11 %).
CubeLevel cube_from_map(const EnvMap& map, int face_size) {
  CubeLevel c;
  c.face_size = face_size;
  const size_t texels = size_t(face_size) * size_t(6 * face_size);
  c.rgb.assign(texels * 3, 0.0f);
  std::vector<double> sum(texels * 3, 0.0), weight(texels, 0.0);
  const Imath::Box2i dw = cube_window(face_size);
  auto texel_of = [&](Vec3 world) {
    const Vec3 e = openexr_from_world(world);
    Imf::CubeMapFace face;
    Imath::V2f pif;
    Imf::CubeMap::faceAndPixelPosition(Imath::V3f(float(e.x), float(e.y), float(e.z)), dw, face, pif);
    const Imath::V2f p = Imf::CubeMap::pixelPosition(
        face, dw, Imath::V2f(std::clamp(std::round(pif.x), 0.0f, float(face_size - 1)),
                             std::clamp(std::round(pif.y), 0.0f, float(face_size - 1))));
    return size_t(std::lround(p.y)) * size_t(face_size) + size_t(std::lround(p.x));
  };
  const double texel_solid_angle = 4 * kPi / double(texels);
  for (size_t p = 0; p < map.pixel_count(); ++p) {
    const double omega = pixel_solid_angle(map, p);
    const int k = map.layout == Layout::LatLong ? std::clamp(int(std::ceil(std::sqrt(4 * omega / texel_solid_angle))), 1, 16) : 1;
    const int u = int(p % size_t(map.width)), v = int(p / size_t(map.width));
    for (int a = 0; a < k; ++a)
      for (int b = 0; b < k; ++b) {
        Vec3 d = pixel_direction(map, p);
        double w = omega;
        if (k > 1) {
          const double theta = kPi * (v + (b + 0.5) / k) / map.height, phi = 2 * kPi * (u + (a + 0.5) / k) / map.width;
          d = direction_from_angles(theta, phi);
          w = omega * std::sin(theta) / (k * k * std::max(1e-12, std::sin(kPi * (v + 0.5) / map.height)));
        }
        const size_t t = texel_of(d);
        for (int ch = 0; ch < 3; ++ch) sum[3 * t + size_t(ch)] += w * map.pixel(p)[ch];
        weight[t] += w;
      }
  }
  for_each_texel(face_size, [&](size_t pixel, int, float, float, Vec3 d) {
    if (weight[pixel] > 0) {
      for (int ch = 0; ch < 3; ++ch) c.rgb[3 * pixel + size_t(ch)] = float(sum[3 * pixel + size_t(ch)] / weight[pixel]);
    } else if (const auto p = pixel_at(map, world_from_openexr(normalize(d)))) {
      for (int ch = 0; ch < 3; ++ch) c.rgb[3 * pixel + size_t(ch)] = map.pixel(*p)[ch];
    }
  });
  return c;
}

// Every texel of a cube level as a direction (OpenEXR frame), its solid angle (the cube's
// area element at the texel; texels on an edge or corner are shared by two or three faces,
// so they weigh 1/2 or 1/4) and its value.
struct TexelList {
  std::vector<Vec3> direction;
  std::vector<double> solid_angle;
  std::vector<std::array<double, 3>> rgb;
};

TexelList texels_of(const CubeLevel& c) {
  const size_t count = size_t(6) * size_t(c.face_size) * size_t(c.face_size);
  TexelList t;
  t.direction.resize(count);
  t.solid_angle.resize(count);
  t.rgb.resize(count);
  const int n = c.face_size;
  const double step = n > 1 ? 2.0 / (n - 1) : 2.0;
  for_each_texel(n, [&](size_t pixel, int, float i, float j, Vec3 d) {
    const double len = length(d);
    double w = step * step / (len * len * len);  // d = (u, v, 1) up to axis order: dA / |d|^3
    if (n > 1 && (i == 0 || i == n - 1)) w *= 0.5;
    if (n > 1 && (j == 0 || j == n - 1)) w *= 0.5;
    t.direction[pixel] = (1 / len) * d;
    t.solid_angle[pixel] = w;
    for (int ch = 0; ch < 3; ++ch) t.rgb[pixel][size_t(ch)] = c.rgb[3 * pixel + size_t(ch)];
  });
  return t;
}

// One level by direct summation over the source mip of the same face size: for each texel R,
// sum of L(l) D(h) (R.l) dOmega over the source texels with R.l > 0, normalised. Exact up to
// the source's resolution, with no sampling noise around small bright sources (Monte Carlo
// importance sampling of D, even filtered, left 10-16 % RMS errors on a church window).
CubeLevel prefilter_level(const CubePyramid& source, int face_size, double roughness) {
  const CubeLevel* src = &source.levels[0];
  for (const CubeLevel& l : source.levels)
    if (l.face_size == face_size) src = &l;
  const TexelList t = texels_of(*src);
  CubeLevel c;
  c.face_size = face_size;
  c.roughness = roughness;
  c.rgb.assign(size_t(face_size) * size_t(6 * face_size) * 3, 0.0f);
  const double alpha = roughness * roughness;
  for_each_texel(face_size, [&](size_t pixel, int, float, float, Vec3 d) {
    const Vec3 r = normalize(d);
    double sum[3] = {0, 0, 0}, weight = 0;
    for (size_t k = 0; k < t.direction.size(); ++k) {
      const Vec3& l = t.direction[k];
      const double n_dot_l = dot(r, l);
      if (n_dot_l <= 0) continue;
      const double n_dot_h = std::sqrt(0.5 * (1 + n_dot_l));  // h = (l + r) / |l + r|
      const double w = ggx_d(n_dot_h, alpha) * n_dot_l * t.solid_angle[k];
      for (int ch = 0; ch < 3; ++ch) sum[ch] += w * t.rgb[k][size_t(ch)];
      weight += w;
    }
    for (int ch = 0; ch < 3; ++ch) c.rgb[3 * pixel + size_t(ch)] = weight > 0 ? float(sum[ch] / weight) : 0.0f;
  });
  return c;
}

}  // namespace

PrefilteredCube prefilter_ggx(const EnvMap& map, const PrefilterOptions& options, const std::string& label) {
  const std::string of = label.empty() ? "" : label + ": ";
  const int n = options.face_size;
  if (n < 4 || n > 2048 || (n & (n - 1)))
    throw InputError(fmt::format("--size: the face size must be a power of two in [4, 2048], got {}", n));
  const int m = options.min_face_size;
  if (m < 1 || m > n || (m & (m - 1)))
    throw InputError(fmt::format("--min-size: the smallest face must be a power of two in [1, {}], got {}", n, m));
  if (map.layout == Layout::Hemisphere)
    throw InputError(of + "a hemisphere map covers the upper half only: the prefiltered cube needs the whole sphere");
  if (!map.valid.empty() && std::count(map.valid.begin(), map.valid.end(), uint8_t(0)) > 0)
    throw InputError(of + "the map has invalid pixels (a blind spot?): fill them first, the prefiltered cube needs the whole sphere");
  CubePyramid source;
  source.levels.push_back(cube_from_map(map, n));
  while (source.levels.back().face_size > 1) source.levels.push_back(downsample(source.levels.back()));
  PrefilteredCube out;
  out.units = map.units;
  int count = 1;  // cube levels down to the smallest face: log2(n / m) + 1
  while ((n >> (count - 1)) > m) ++count;
  out.levels.push_back(source.levels[0]);
  for (int k = 1; k < count; ++k)
    out.levels.push_back(prefilter_level(source, n >> k, double(k) / (count - 1)));
  return out;
}

std::array<double, 3> prefiltered_radiance_brute_force(const EnvMap& map, Vec3 world_direction, double roughness) {
  const Vec3 r = normalize(world_direction);
  const double alpha = roughness * roughness;
  double sum[3] = {0, 0, 0}, weight = 0;
  for (size_t p = 0; p < map.pixel_count(); ++p) {
    if (!map.is_valid(p)) continue;
    const Vec3 l = pixel_direction(map, p);
    const double n_dot_l = dot(r, l);
    if (n_dot_l <= 0) continue;
    const double w = ggx_d(dot(r, normalize(l + r)), alpha) * n_dot_l * pixel_solid_angle(map, p);
    for (int ch = 0; ch < 3; ++ch) sum[ch] += w * map.pixel(p)[ch];
    weight += w;
  }
  return {sum[0] / weight, sum[1] / weight, sum[2] / weight};
}

std::array<double, 3> prefiltered_lookup(const PrefilteredCube& cube, int level, Vec3 world_direction) {
  return cube_bilinear(cube.levels.at(size_t(level)), openexr_from_world(normalize(world_direction)));
}

namespace {
// Height-correlated Smith visibility V = G2 / (4 n.l n.v) (Heitz 2014, as Filament uses it).
double smith_ggx_visibility(double n_dot_v, double n_dot_l, double alpha) {
  const double a2 = alpha * alpha;
  const double gv = n_dot_l * std::sqrt(n_dot_v * n_dot_v * (1 - a2) + a2);
  const double gl = n_dot_v * std::sqrt(n_dot_l * n_dot_l * (1 - a2) + a2);
  return 0.5 / (gv + gl);
}
}  // namespace

DfgTable compute_dfg_table(int size, int samples) {
  if (size < 2 || size > 4096) throw InputError(fmt::format("--lut-size must be in [2, 4096], got {}", size));
  if (samples < 16 || samples > 1 << 20) throw InputError(fmt::format("DFG samples must be in [16, 2^20], got {}", samples));
  DfgTable t;
  t.size = size;
  t.ab.assign(size_t(size) * size_t(size) * 2, 0.0f);
  // The samples' half vectors depend on the row's roughness only, their azimuths on nothing:
  // computed once a row instead of once an entry. The sin, cos and
  // pow of every sample of every entry were 7.4 s of `prefilter --lut` (128 x 128 entries,
  // 16384 samples) on two cores; (1 - v.h)^5 is multiplied out.
  // (v has no y, so the half vectors' y, sin phi, is never needed.)
  std::vector<double> cos_phi(static_cast<size_t>(samples));
  for (int i = 0; i < samples; ++i) cos_phi[size_t(i)] = std::cos(2 * kPi * radical_inverse(uint64_t(i), 2));
  tbb::parallel_for(0, size, [&](int row) {
    const double roughness = (row + 0.5) / size, alpha = roughness * roughness;
    std::vector<double> hx(static_cast<size_t>(samples)), hz(static_cast<size_t>(samples));
    for (int i = 0; i < samples; ++i) {
      const Vec3 h = ggx_half_vector((i + 0.5) / samples, 0.0, alpha);  // phi = 0: (sin t, 0, cos t)
      hx[size_t(i)] = h.x * cos_phi[size_t(i)], hz[size_t(i)] = h.z;
    }
    for (int col = 0; col < size; ++col) {
      const double n_dot_v = (col + 0.5) / size, v_x = std::sqrt(1 - n_dot_v * n_dot_v);
      double a = 0, b = 0;
      for (size_t i = 0; i < size_t(samples); ++i) {
        const double v_dot_h = v_x * hx[i] + n_dot_v * hz[i];  // v = (v_x, 0, n.v)
        const double l_z = 2 * v_dot_h * hz[i] - n_dot_v;      // l = 2 (v.h) h - v
        if (l_z <= 0 || v_dot_h <= 0) continue;
        // f n.l / pdf with pdf = D n.h / (4 v.h): the D cancels.
        const double w = 4 * smith_ggx_visibility(n_dot_v, l_z, alpha) * l_z * v_dot_h / hz[i];
        const double x = 1 - v_dot_h, x2 = x * x, fc = x2 * x2 * x;
        a += (1 - fc) * w;
        b += fc * w;
      }
      t.ab[2 * (size_t(row) * size_t(size) + size_t(col))] = float(a / samples);
      t.ab[2 * (size_t(row) * size_t(size) + size_t(col)) + 1] = float(b / samples);
    }
  });
  return t;
}

std::array<double, 2> dfg_by_quadrature(double n_dot_v, double roughness) {
  const double alpha = roughness * roughness;
  const Vec3 v{std::sqrt(1 - n_dot_v * n_dot_v), 0, n_dot_v};
  constexpr int kTheta = 1500, kPhi = 1500;
  double a = 0, b = 0;
  for (int i = 0; i < kTheta; ++i) {
    const double theta = (i + 0.5) * (kPi / 2) / kTheta, st = std::sin(theta), ct = std::cos(theta);
    const double d_omega = st * (kPi / 2 / kTheta) * (2 * kPi / kPhi);
    for (int j = 0; j < kPhi; ++j) {
      const double phi = (j + 0.5) * 2 * kPi / kPhi;
      const Vec3 l{st * std::cos(phi), st * std::sin(phi), ct};
      const Vec3 h = normalize(l + v);
      const double f = ggx_d(h.z, alpha) * smith_ggx_visibility(n_dot_v, ct, alpha) * ct * d_omega;
      const double fc = std::pow(1 - dot(v, h), 5);
      a += (1 - fc) * f;
      b += fc * f;
    }
  }
  return {a, b};
}

void check_prefiltered_cube_path(const std::string& path) {
  if (lower_extension(path) != ".exr") throw InputError(path + ": the prefiltered cube is written as OpenEXR (.exr)");
}

void write_prefiltered_cube(const std::string& path, const PrefilteredCube& cube) {
  check_prefiltered_cube_path(path);
  if (cube.levels.empty()) throw InputError(path + ": no cube levels to write");
  const int n = cube.levels[0].face_size;
  Imf::Header header(n, 6 * n);
  header.compression() = Imf::ZIP_COMPRESSION;
  for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
  header.setTileDescription(Imf::TileDescription(32, 32, Imf::MIPMAP_LEVELS, Imf::ROUND_DOWN));
  Imf::addEnvmap(header, Imf::ENVMAP_CUBE);
  std::vector<float> roughness;
  for (const CubeLevel& l : cube.levels) roughness.push_back(float(l.roughness));
  header.insert("lightprobe.roughness", Imf::FloatVectorAttribute(roughness));
  header.insert("lightprobe.units", Imf::StringAttribute(std::string(to_string(cube.units))));
  header.insert("lightprobe.frame", Imf::StringAttribute("openexr = (y, z, -x) of the z-up world"));
  Imf::StdOSStream os;
  {
    Imf::TiledOutputFile out(os, header);
    std::vector<float> filler;
    std::vector<CubeLevel> extra;
    for (int level = 0; level < out.numLevels(); ++level) {
      const Imath::Box2i dw = out.dataWindowForLevel(level);
      const int w = dw.max.x - dw.min.x + 1, h = dw.max.y - dw.min.y + 1;
      const float* data = nullptr;
      if (level < int(cube.levels.size()) && cube.levels[size_t(level)].face_size == w && h == 6 * w) {
        data = cube.levels[size_t(level)].rgb.data();
      } else if (h == 6 * w) {  // past the chain, still a cube: the previous level box-filtered
        extra.push_back(downsample(extra.empty() ? cube.levels.back() : extra.back()));
        data = extra.back().rgb.data();
      } else {  // OpenEXR's last levels (width 1, height below 6): the last level's mean
        const std::vector<float>& last = cube.levels.back().rgb;
        double mean[3] = {0, 0, 0};
        for (size_t i = 0; i < last.size(); ++i) mean[i % 3] += last[i];
        filler.assign(size_t(w) * size_t(h) * 3, 0.0f);
        for (size_t i = 0; i < filler.size(); ++i) filler[i] = float(mean[i % 3] / double(last.size() / 3));
        data = filler.data();
      }
      Imf::FrameBuffer fb;
      const size_t xs = 3 * sizeof(float), ys = xs * size_t(w);
      char* base = reinterpret_cast<char*>(const_cast<float*>(data));
      for (int ch = 0; ch < 3; ++ch)
        fb.insert(std::string(1, "RGB"[ch]), Imf::Slice(Imf::FLOAT, base + size_t(ch) * sizeof(float), xs, ys));
      out.setFrameBuffer(fb);
      out.writeTiles(0, out.numXTiles(level) - 1, 0, out.numYTiles(level) - 1, level);
    }
  }
  write_file_atomically(path, os.str());
}

void write_dfg_table(const std::string& path, const DfgTable& table) {
  RgbImage img;
  img.width = img.height = table.size;
  img.rgb.assign(size_t(table.size) * size_t(table.size) * 3, 0.0f);
  for (size_t i = 0; i < size_t(table.size) * size_t(table.size); ++i) {
    img.rgb[3 * i] = table.ab[2 * i];
    img.rgb[3 * i + 1] = table.ab[2 * i + 1];
  }
  write_rgb_image(path, img);
}

}  // namespace lp
