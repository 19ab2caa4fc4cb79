// Internal: Havran's inverse transform on the hemisphere (Havran, Dmitriev, Seidel 2003,
// "Goniometric diagram mapping for hemisphere"; used by Havran et al. EGSR 2005 and
// called Hemigon by Nikodym et al.), exposed so that tests and tools can warp arbitrary
// points of the unit square. The Sampler (make_hemigon_sampler) is built on it.
//
// The warp, for a `hemisphere` map (polar: phi = 2 pi (u+1/2)/W, theta = (pi/2)(v+1/2)/H):
//   1. (x, y) in the unit square -> disc point (r_d, phi_d) by the concentric map;
//      xi1 = r_d^2 and xi2 = phi_d / (2 pi) are then uniform in [0, 1)^2 when (x, y) is.
//   2. The marginal inverse CDF turns xi1 into s = r^2 = 1 - cos(theta). The measure
//      ds dphi is exactly solid angle, so a pixel's (s, phi) area is its solid angle.
//   3. The conditional inverse CDF at that s turns xi2 into phi.
//   4. (s, phi) -> d = (sin t cos phi, sin t sin phi, 1 - s): disc area is proportional to
//      solid angle (cos theta = 1 - r^2).
//
// The density that is sampled exactly (up to rounding) is
//   f(s, phi) = (1 - t) Y[v][u] + t Y[v+1][u]   for s between the knots k_v and k_v+1,
// with t = (s - k_v) / (k_v+1 - k_v), u the column holding phi and Y the luminance of
// valid pixels (0 for invalid ones); below the horizon-most knot the last ring's own value
// is used. k_0 = 0 is the pole and the knots sit within 1/6 ring of the ring midpoints,
// placed so that every pixel keeps exactly its power (sum Y * solid angle), and a constant
// map gives a constant f (see build()). f is piecewise constant in phi and piecewise
// linear in s: the map's luminance interpolated linearly between neighbouring rings.
// Consequences:
//   - the marginal density in s is piecewise linear (its CDF piecewise quadratic, inverted
//     in closed form); the conditional CDF over phi at s is the blend
//     (1 - t) C_v(phi) + t C_v+1(phi) of the two rings' unnormalised CDFs, i.e. their
//     normalised CDFs blended with weight t T_v+1 / ((1 - t) T_v + t T_v+1) (T: ring
//     totals) -- the "linear interpolation between neighbouring 1D CDFs" of the papers,
//     weighted by the rings' powers so that the density above holds exactly;
//   - the warp is continuous wherever f > 0, also across phi = 0 (the concentric map's
//     cut is mapped to phi = 0 and phi = 2 pi, the same meridian) and across ring
//     boundaries, and bijective between the open square and the support of f; where f
//     vanishes on a band (a black or invalid region) points jump across it, as any
//     continuous-density inverse must;
//   - a light can land up to one ring away from the pixel whose power it carries (a
//     one-pixel sun spreads over +-1 ring in theta, not at all in phi).
#pragma once

#include <array>
#include <vector>

#include "core/envmap.h"
#include "core/vec3.h"

namespace lp {

class HemigonWarp {
 public:
  // Builds the CDFs of a `hemisphere` layout map. Throws InputError for other layouts and
  // for NaN or negative pixels.
  // Buffers are reused across calls. A black map builds, with power() == 0; warping it is
  // then undefined. With `borrow` see below.
  void build(const EnvMap& hemisphere_map, bool borrow = false);

  // The same from the map's rows given one by one: row v of a width x height hemisphere map
  // is rows[v] (packed RGB, read right to left when `reversed`; valid null: all valid). Lets
  // the sampler take both halves of a latlong map whose rows are the hemisphere's rows
  // without resampling it. With `rgb_power` false the per-channel sums are left out
  // (rgb_power() is then zero): a pass over the colours a caller that takes the power of the
  // whole map from elsewhere does not need (a third of hemigon's prepare on a latlong map).
  // With `borrow`, the rows are not copied (the copy was a third of the sampler's prepare):
  // warp() then reads each sample's colour from the rows' pixels (and masks), which must
  // stay alive and unchanged as long as the warp is used (the sampler's frame).
  struct Row {
    const float* rgb = nullptr;
    const uint8_t* valid = nullptr;
    bool reversed = false;
  };
  // With `row_sums` (3 per row), each row's channel sums as the row is stored (left to right,
  // its mask ignored), taken while the row is in cache: for an unmasked map, the per-row sums
  // core/envmap.h's total_power adds (the sampler's target power without a pass of its own).
  void build(int width, int height, const Row* rows, bool rgb_power = true, bool borrow = false,
             double* row_sums = nullptr);

  struct Sample {
    Vec3 direction;                // unit, z >= 0
    std::array<double, 3> rgb{};   // interpolated radiance at the sample (f's colour)
    double luminance = 0;          // f at the sample: luminance of rgb
  };
  // Warps (x, y) in [0, 1]^2.
  Sample warp(double x, double y) const;

  // Luminance power of the map: integral of f = sum of Y * pixel solid angle.
  double power() const { return power_; }
  // Per-channel power sum L * solid angle over valid pixels (zero when built without).
  const std::array<double, 3>& rgb_power() const { return rgb_power_; }
  int width() const { return width_; }
  int height() const { return height_; }

 private:
  int width_ = 0, height_ = 0;
  double dphi_ = 0;
  // Pixel u of ring v's colour: in rgb_, or in the borrowed rows.
  const float* pixel(int v, int u) const;

  std::vector<float> rgb_;        // valid pixels' radiance, 0 for invalid (unless borrowed)
  std::vector<Row> borrowed_;     // the rows warp() reads, when not copied to rgb_
  std::vector<double> cum_;       // height x (width + 1): running sums of Y along each row
  std::vector<double> bounds_;    // height + 2 segment bounds in s: 0, c_0 .. c_{H-1}, 1
  std::vector<double> seg_cum_;   // height + 2: marginal mass before each segment bound
  std::vector<double> row_density_;  // height: dphi * sum_u Y (ring luminance per unit s)
  std::vector<double> knots_;        // height: s where each ring's value sits (see build)
  int knots_height_ = -1;
  double power_ = 0;
  std::array<double, 3> rgb_power_{0, 0, 0};
  std::vector<float> lum_;  // scratch: clamped luminance of the rows being swept
  std::vector<float> scratch_;  // scratch: borrowed masked or reversed rows' colours, for their sums
};

// The first n Halton points (bases 2, 3; indices 1..n) after Lloyd relaxation on the unit
// square as a torus (discrete Lloyd on a grid of at least 256 x 256 cells, ~64 per point,
// 40 iterations), in [0, 1)^2. Point k - 1 belongs to Halton index k. Computed once per n
// and cached; thread-safe. Blue noise trades the Halton points' axis stratification:
// better on smooth maps, worse than plain Halton with small bright sources (see report).
const std::vector<std::array<double, 2>>& lloyd_relaxed_halton(int n);

}  // namespace lp
