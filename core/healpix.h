// HEALPix pixels in the NESTED scheme (Górski et al. 2005, ApJ 622:759): pixel centre
// <-> direction for nside a power of two, 12 nside^2 pixels.
//
// Written here rather than called in chealpix: libchealpix.so links cfitsio, and through it
// curl, GnuTLS, Kerberos and LDAP - 35 shared libraries that every lightprobe command loaded
// at start for these two functions. These give bit-identical results to chealpix's
// pix2vec_nest64 and vec2pix_nest64 (the same operations in the same order, tested against
// chealpix on every pixel of small maps and millions of random ones: tests/core/healpix_test.cpp),
// and inline where chealpix's cannot.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/vec3.h"

namespace lp {

// Unit vector of the centre of `pixel` (0 <= pixel < 12 nside^2).
Vec3 healpix_direction(int64_t nside, int64_t pixel);
// The pixel holding `direction` (any non-zero length).
int64_t healpix_pixel(int64_t nside, Vec3 direction);
// The same from the direction's z = cos theta, sin theta and azimuth phi in [0, 2 pi): what
// healpix_pixel computes from a vector (sin theta is read only where |z| > 0.99), for callers
// that know them exactly, a latlong grid's rows and columns, without a square root and an
// arc tangent per pixel.
int64_t healpix_pixel_at(int64_t nside, double z, double sin_theta, double phi);
// A point inside `pixel` at (u1, u2) in [0, 1]^2 of its face coordinates (0.5, 0.5: the
// centre), through the inverse HEALPix projection (HEALPix C++'s xyf2loc; Calabretta &
// Roukema 2007): uniform (u1, u2) give points uniform in solid angle over the pixel, as
// all HEALPix pixels have equal area and the projection is equal-area.
Vec3 healpix_point(int64_t nside, int64_t pixel, double u1, double u2);

// NESTED index <-> (face, ix, iy) within the face (the file layout of core/image_io.h).
size_t healpix_nested_index(int nside, int face, int ix, int iy);
void healpix_face_xy(int nside, size_t nested, int* face, int* ix, int* iy);

}  // namespace lp
