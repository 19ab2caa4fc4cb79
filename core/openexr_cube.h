// OpenEXR's cube-map layout (ImfEnvmap.h, the standard attribute envmap = cube): one image
// N wide and 6 N tall holding the faces +X, -X, +Y, -Y, +Z, -Z of a y-up frame, each stored
// turned as ImfEnvmap.h draws it, with the face's outer texels on the cube's edges (texel
// centres at face positions 0 .. N - 1, not at (i + 1/2) / N as OpenGL's). exrenvmap, Nuke's
// OpenEXR writer and `lightprobe prefilter` write it.
//
// Frame: openexr = (y, z, -x) of the world direction (z-up), the mapping under which a
// lightprobe latlong map read with OpenEXR's latlong convention (envmap = latlong) shows the
// same directions (to half a pixel: OpenEXR's latlong puts pixel centres on the poles and
// at +-pi, ours half a pixel in, so an envmap = latlong file is read as our latlong, a
// stretch of 1 / H); OpenEXR's frame is left-handed against ours, so this is a mirror, not a
// turn. OpenEXR's own exrenvmap checks it both ways (tests/render/prefilter_test.cpp,
// tests/core/openexr_cube_test.cpp).
#pragma once

#include <array>
#include <vector>

#include "core/envmap.h"
#include "core/vec3.h"

namespace lp {

// World (z-up) <-> OpenEXR envmap frame (y-up).
Vec3 openexr_from_world(Vec3 d);
Vec3 world_from_openexr(Vec3 d);

// Bilinear lookup of a stacked cube image (`rgb`: N x 6 N texels, 3 floats each) at
// position (x, y) of one face (0 .. 5 as Imf::CubeMapFace, positions as ImfEnvmap.h numbers
// them, 0 .. N - 1), clamped at the face's edges: no filtering across faces.
std::array<double, 3> openexr_face_bilinear(const std::vector<float>& rgb, int face_size, int face, double x, double y);
// The same in an OpenEXR-frame direction (any non-zero length), within the face it falls on.
std::array<double, 3> openexr_cube_bilinear(const std::vector<float>& rgb, int face_size, Vec3 exr_direction);

// The cube as a latlong map in the world frame, 4 N x 2 N (a face's texel pitch at the
// equator). Each pixel averages 2 x 2 sub-samples equally spaced in phi and cos(theta)
// (equal solid angles), each a bilinear lookup: the total power agrees with the cube's to
// well under 1 % for content smoother than a texel (tested against an analytic sky).
// std::invalid_argument unless rgb holds N x 6 N texels, N >= 1.
EnvMap openexr_cube_to_latlong(const std::vector<float>& rgb, int face_size);

}  // namespace lp
