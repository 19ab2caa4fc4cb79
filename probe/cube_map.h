// Cube-map probes (six square faces) -> environment maps in the world frame.
//
// Faces and their texel coordinates follow the OpenGL / WebGL cube-map convention
// (OpenGL 4.6 core spec, table 8.19 "Selection of cube map images"; three.js
// CubeTextureLoader order px, nx, py, ny, pz, nz). For a direction r = (rx, ry, rz) in
// the CUBE frame, the face is that of the major axis ma (largest |component|) and
//   face +x (px): sc = -rz, tc = -ry, ma = rx      face -x (nx): sc = +rz, tc = -ry, ma = rx
//   face +y (py): sc = +rx, tc = +rz, ma = ry      face -y (ny): sc = +rx, tc = -rz, ma = ry
//   face +z (pz): sc = +rx, tc = -ry, ma = rz      face -z (nz): sc = -rx, tc = -ry, ma = rz
//   s = (sc / |ma| + 1) / 2,  t = (tc / |ma| + 1) / 2.
// s grows to the right (column), t grows downwards: t = 0 is the TOP row of the stored
// image (the first row uploaded to glTexImage2D, which three.js does without flipY for
// cube textures). Texel (i, j) (column i, row j) of an N x N face has its centre at
// s = (i + 1/2) / N, t = (j + 1/2) / N.
//
// Frame. The cube frame above is left-handed as OpenGL uses it: the faces are stored
// as seen from inside the cube, which in a right-handed world means the x axis is
// mirrored. three.js accounts for this by looking up a CubeTexture at
// (-x, y, z) of its (right-handed, Y-up) world direction (`flipEnvMap = -1`). We do the
// same, then turn the Y-up three.js world into our Z-up world:
//   world = world_from_cube * S * r,   S = diag(-1, 1, 1) if mirror_x else identity,
//   default world_from_cube = Rx(+90 deg): (x, y, z) -> (x, -z, y)  (a proper rotation).
// So by default: cube +y (py) -> world +Z (zenith), cube -y -> nadir,
// cube +x (px) -> world -X, cube -x (nx) -> world +X,
// cube +z (pz) -> world -Y, cube -z (nz) -> world +Y
// (three.js's default camera looks along its -Z, i.e. world +Y; nz is the view ahead).
// With mirror_x the image of each face is seen un-mirrored from the cube's centre.
//
// Resampling: each destination pixel averages k x k sub-samples, equally spaced in phi
// and cos theta over the pixel (equal solid angle each; k = samples_per_edge), each
// looked up in its face with bilinear interpolation of texel centres, clamped at the
// face's edges (no filtering across faces). Nothing is renormalised afterwards; the
// total power agrees with cube_power() (exact texel solid angles) to well under 1 % for
// smooth content. Healpix destinations go through a latlong intermediate (at least
// 4 samples per face texel edge) and core resample(), which keeps power.
//
// All failures throw lp::InputError with a one-line message naming the file.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/vec3.h"

namespace lp {

// Face index order: px, nx, py, ny, pz, nz (0..5).
enum class CubeFace { PX = 0, NX = 1, PY = 2, NY = 3, PZ = 4, NZ = 5 };
// "px", "nx", "py", "ny", "pz", "nz".
const char* cube_face_name(int face);

struct CubeMapOptions {
  // Sub-samples per destination pixel edge (k x k per pixel); >= 1.
  int samples_per_edge = 4;
  // Undo the left-handed OpenGL cube frame by negating x (three.js flipEnvMap).
  bool mirror_x = true;
  // Proper rotation from the (mirror-corrected) cube frame to the world frame.
  // Default: Y-up -> Z-up, (x, y, z) -> (x, -z, y).
  Mat3 world_from_cube{{1, 0, 0, 0, 0, -1, 0, 1, 0}};
};

// Face and texel coordinates (s, t in [0, 1], t = 0 top row) of a CUBE-frame direction
// (any non-zero length), per the table above.
struct CubeTexelCoord {
  int face = 0;
  double s = 0, t = 0;
};
CubeTexelCoord cube_face_coord(Vec3 cube_direction);
// Inverse: unit CUBE-frame direction of face coordinates (s, t).
Vec3 cube_face_direction(int face, double s, double t);
// Full frame mapping with options: world direction of a cube-frame direction and back.
Vec3 world_from_cube_direction(Vec3 cube_direction, const CubeMapOptions& options = {});
Vec3 cube_from_world_direction(Vec3 world_direction, const CubeMapOptions& options = {});
// Unit world direction of the centre of texel (i, j) (column, row) of an N x N face.
Vec3 cube_texel_world_direction(int face, int i, int j, int face_size, const CubeMapOptions& options = {});

// Exact solid angle of texel (i, j) of an N x N face of a unit cube, from its corners
// with the area element atan2(x y, sqrt(x^2 + y^2 + 1)). The 6 N^2 texels sum to 4 pi.
double cube_texel_solid_angle(int i, int j, int face_size);
// Integral of radiance over the sphere, per channel: sum of texel value * solid angle.
std::array<double, 3> cube_power(const std::array<std::vector<float>, 6>& faces_rgb, int face_size);

// Convert six N x N float RGB faces (row-major, 3 floats per texel, row 0 on top) into a
// map of `layout` (width x height; healpix: width is nside) in the world frame.
EnvMap cube_map_to_envmap(const std::array<std::vector<float>, 6>& faces_rgb, int face_size, Layout layout,
                          int width, int height, const CubeMapOptions& options = {});

// Six faces as read from files.
struct CubeFaces {
  int face_size = 0;
  std::array<std::vector<float>, 6> rgb;
  std::array<std::string, 6> paths;
  Units units = Units::Relative;
};
// `directory_or_pattern`: a directory holding px, nx, py, ny, pz, nz with extension
// .hdr, .exr or .pfm (first found in that order), or a path containing "{face}", which
// is replaced by each face name (with no extension, the three are tried as above).
// Faces must be square, all the same size, free of validity masks and agree on units.
CubeFaces read_cube_faces(const std::string& directory_or_pattern);
EnvMap read_cube_map(const std::string& directory_or_pattern, Layout layout, int width, int height,
                     const CubeMapOptions& options = {});

}  // namespace lp
