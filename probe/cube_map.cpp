#include "probe/cube_map.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <string>

#include "core/error.h"
#include "core/image_io.h"
#include "core/resample.h"

namespace lp {
namespace {

constexpr const char* kFaceNames[6] = {"px", "nx", "py", "ny", "pz", "nz"};
constexpr const char* kExtensions[3] = {".hdr", ".exr", ".pfm"};

Mat3 mirror_matrix(bool mirror_x) {
  return mirror_x ? Mat3{{-1, 0, 0, 0, 1, 0, 0, 0, 1}} : Mat3{};
}

void check_options(const CubeMapOptions& options) {
  if (options.samples_per_edge < 1)
    throw InputError("cube map: samples_per_edge must be at least 1, got " +
                     std::to_string(options.samples_per_edge));
  if (!is_rotation(options.world_from_cube))
    throw InputError("cube map: world_from_cube is not a rotation (orthonormal, determinant +1)");
}

// Bilinear lookup of texel centres, clamped at the face's edges.
void sample_face(const std::vector<float>& face, int n, double s, double t, double* out) {
  const double x = std::clamp(s * n - 0.5, 0.0, double(n - 1));
  const double y = std::clamp(t * n - 0.5, 0.0, double(n - 1));
  const int i0 = std::min(int(x), n - 1), j0 = std::min(int(y), n - 1);
  const int i1 = std::min(i0 + 1, n - 1), j1 = std::min(j0 + 1, n - 1);
  const double fx = x - i0, fy = y - j0;
  const float* a = &face[3 * (size_t(j0) * n + i0)];
  const float* b = &face[3 * (size_t(j0) * n + i1)];
  const float* c = &face[3 * (size_t(j1) * n + i0)];
  const float* d = &face[3 * (size_t(j1) * n + i1)];
  for (int k = 0; k < 3; ++k)
    out[k] = (1 - fy) * ((1 - fx) * a[k] + fx * b[k]) + fy * ((1 - fx) * c[k] + fx * d[k]);
}

// Area element of the unit cube face seen from its centre: the solid angle of the
// rectangle [0, x] x [0, y] on the plane at distance 1.
double area_element(double x, double y) { return std::atan2(x * y, std::sqrt(x * x + y * y + 1)); }

void check_faces(const std::array<std::vector<float>, 6>& faces_rgb, int face_size) {
  if (face_size < 1) throw InputError("cube map: face size must be positive, got " + std::to_string(face_size));
  for (int f = 0; f < 6; ++f)
    if (faces_rgb[f].size() != 3 * size_t(face_size) * size_t(face_size))
      throw InputError(std::string("cube map: face ") + kFaceNames[f] + " has " +
                       std::to_string(faces_rgb[f].size()) + " floats, expected 3 x " + std::to_string(face_size) +
                       " x " + std::to_string(face_size));
}

// Row grids (latlong / hemisphere): k x k sub-samples equal in phi and cos theta.
void fill_row_grid(EnvMap& map, const std::array<std::vector<float>, 6>& faces, int n,
                   const CubeMapOptions& options) {
  const Mat3 cube_from_world = mirror_matrix(options.mirror_x) * transpose(options.world_from_cube);
  const double theta_span = map.layout == Layout::LatLong ? M_PI : M_PI / 2;
  const int k = options.samples_per_edge;
  const double dphi = 2 * M_PI / map.width;
  tbb::parallel_for(tbb::blocked_range<int>(0, map.height), [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v < rows.end(); ++v) {
      const double c0 = std::cos(theta_span * v / map.height);
      const double c1 = std::cos(theta_span * (v + 1) / map.height);
      for (int u = 0; u < map.width; ++u) {
        double sum[3] = {0, 0, 0};
        for (int a = 0; a < k; ++a) {
          const double cos_t = c0 + (c1 - c0) * (a + 0.5) / k;
          const double sin_t = std::sqrt(std::max(0.0, 1 - cos_t * cos_t));
          for (int b = 0; b < k; ++b) {
            const double phi = dphi * (u + (b + 0.5) / k);
            const Vec3 w{sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
            const CubeTexelCoord tc = cube_face_coord(cube_from_world * w);
            double value[3];
            sample_face(faces[tc.face], n, tc.s, tc.t, value);
            for (int c = 0; c < 3; ++c) sum[c] += value[c];
          }
        }
        float* p = map.pixel(size_t(v) * map.width + u);
        for (int c = 0; c < 3; ++c) p[c] = float(sum[c] / (k * k));
      }
    }
  });
}

std::string find_face_file(const std::string& directory_or_pattern, int face) {
  namespace fs = std::filesystem;
  std::string base;
  const std::string token = "{face}";
  const size_t at = directory_or_pattern.find(token);
  if (at != std::string::npos) {
    base = directory_or_pattern;
    base.replace(at, token.size(), kFaceNames[face]);
    if (fs::path(base).has_extension()) {
      if (!fs::is_regular_file(base)) throw InputError(base + ": missing cube face " + kFaceNames[face]);
      return base;
    }
  } else {
    if (!fs::is_directory(directory_or_pattern))
      throw InputError(directory_or_pattern + ": not a directory (and no {face} in the pattern)");
    base = (fs::path(directory_or_pattern) / kFaceNames[face]).string();
  }
  for (const char* ext : kExtensions)
    if (fs::is_regular_file(base + ext)) return base + ext;
  throw InputError(base + ".{hdr,exr,pfm}: missing cube face " + kFaceNames[face]);
}

}  // namespace

const char* cube_face_name(int face) { return (face >= 0 && face < 6) ? kFaceNames[face] : "?"; }

CubeTexelCoord cube_face_coord(Vec3 r) {
  const double ax = std::fabs(r.x), ay = std::fabs(r.y), az = std::fabs(r.z);
  CubeTexelCoord out;
  double sc, tc, ma;
  if (ax >= ay && ax >= az) {
    ma = ax;
    if (r.x >= 0) { out.face = 0; sc = -r.z; tc = -r.y; }
    else          { out.face = 1; sc = +r.z; tc = -r.y; }
  } else if (ay >= az) {
    ma = ay;
    if (r.y >= 0) { out.face = 2; sc = +r.x; tc = +r.z; }
    else          { out.face = 3; sc = +r.x; tc = -r.z; }
  } else {
    ma = az;
    if (r.z >= 0) { out.face = 4; sc = +r.x; tc = -r.y; }
    else          { out.face = 5; sc = -r.x; tc = -r.y; }
  }
  out.s = 0.5 * (sc / ma + 1);
  out.t = 0.5 * (tc / ma + 1);
  return out;
}

Vec3 cube_face_direction(int face, double s, double t) {
  const double sc = 2 * s - 1, tc = 2 * t - 1;
  Vec3 r;
  switch (face) {
    case 0: r = {1, -tc, -sc}; break;
    case 1: r = {-1, -tc, sc}; break;
    case 2: r = {sc, 1, tc}; break;
    case 3: r = {sc, -1, -tc}; break;
    case 4: r = {sc, -tc, 1}; break;
    case 5: r = {-sc, -tc, -1}; break;
    default: throw InputError("cube map: face index " + std::to_string(face) + " out of range 0..5");
  }
  return normalize(r);
}

Vec3 world_from_cube_direction(Vec3 cube_direction, const CubeMapOptions& options) {
  return options.world_from_cube * (mirror_matrix(options.mirror_x) * cube_direction);
}

Vec3 cube_from_world_direction(Vec3 world_direction, const CubeMapOptions& options) {
  return mirror_matrix(options.mirror_x) * (transpose(options.world_from_cube) * world_direction);
}

Vec3 cube_texel_world_direction(int face, int i, int j, int face_size, const CubeMapOptions& options) {
  return world_from_cube_direction(cube_face_direction(face, (i + 0.5) / face_size, (j + 0.5) / face_size), options);
}

double cube_texel_solid_angle(int i, int j, int face_size) {
  const double x0 = 2.0 * i / face_size - 1, x1 = 2.0 * (i + 1) / face_size - 1;
  const double y0 = 2.0 * j / face_size - 1, y1 = 2.0 * (j + 1) / face_size - 1;
  return area_element(x0, y0) - area_element(x0, y1) - area_element(x1, y0) + area_element(x1, y1);
}

std::array<double, 3> cube_power(const std::array<std::vector<float>, 6>& faces_rgb, int face_size) {
  check_faces(faces_rgb, face_size);
  std::array<double, 3> power{0, 0, 0};
  for (int j = 0; j < face_size; ++j)
    for (int i = 0; i < face_size; ++i) {
      const double omega = cube_texel_solid_angle(i, j, face_size);
      for (int f = 0; f < 6; ++f) {
        const float* p = &faces_rgb[f][3 * (size_t(j) * face_size + i)];
        for (int c = 0; c < 3; ++c) power[c] += p[c] * omega;
      }
    }
  return power;
}

EnvMap cube_map_to_envmap(const std::array<std::vector<float>, 6>& faces_rgb, int face_size, Layout layout,
                          int width, int height, const CubeMapOptions& options) {
  check_faces(faces_rgb, face_size);
  check_options(options);
  if (layout == Layout::Healpix) {
    const int nside = width;
    EnvMap check = make_healpix(nside);  // validates nside
    (void)check;
    int w = std::max(8 * nside, 8 * face_size);
    w += w % 2;
    const EnvMap latlong = cube_map_to_envmap(faces_rgb, face_size, Layout::LatLong, w, w / 2, options);
    return resample(latlong, Layout::Healpix, nside, 0);
  }
  EnvMap map = make_envmap(layout, width, height);
  fill_row_grid(map, faces_rgb, face_size, options);
  return map;
}

CubeFaces read_cube_faces(const std::string& directory_or_pattern) {
  CubeFaces faces;
  ReadMapOptions read_options;
  read_options.layout = Layout::Hemisphere;  // any W x H; only the pixels are wanted
  for (int f = 0; f < 6; ++f) {
    const std::string path = find_face_file(directory_or_pattern, f);
    EnvMap image = read_envmap(path, read_options);
    if (image.width != image.height)
      throw InputError(path + ": cube face is " + std::to_string(image.width) + "x" + std::to_string(image.height) +
                       ", not square");
    if (f == 0) {
      faces.face_size = image.width;
      faces.units = image.units;
    } else if (image.width != faces.face_size) {
      throw InputError(path + ": cube face is " + std::to_string(image.width) + "x" +
                       std::to_string(image.height) + " but " + faces.paths[0] + " is " +
                       std::to_string(faces.face_size) + "x" + std::to_string(faces.face_size));
    } else if (image.units != faces.units) {
      throw InputError(path + ": cube face units (" + std::string(to_string(image.units)) + ") differ from " +
                       faces.paths[0] + " (" + std::string(to_string(faces.units)) + ")");
    }
    for (size_t i = 0; i < image.pixel_count(); ++i)
      if (!image.is_valid(i))
        throw InputError(path + ": cube face carries invalid pixels (a validity mask is not supported)");
    faces.rgb[f] = std::move(image.rgb);
    faces.paths[f] = path;
  }
  return faces;
}

EnvMap read_cube_map(const std::string& directory_or_pattern, Layout layout, int width, int height,
                     const CubeMapOptions& options) {
  const CubeFaces faces = read_cube_faces(directory_or_pattern);
  EnvMap map = cube_map_to_envmap(faces.rgb, faces.face_size, layout, width, height, options);
  map.units = faces.units;
  return map;
}

}  // namespace lp
