// Mirror-ball probes: geometry (image point <-> world direction), ball detection, and
// unwrapping into an environment map in the world frame.
//
// Frame (CONVENTIONS.md, with world_from_probe = identity): the camera looks along +X
// at the ball, image up is +Z, image right is -Y; the ball's centre reflects -X (back at
// the camera) and the blind spot, behind the ball, is +X. Image coordinates are pixel
// coordinates, x right, y down, pixel centres at +0.5. With the disc coordinates
//   a = (x - cx) / R (right),  b = -(y - cy) / R (up),  rho^2 = a^2 + b^2 <= 1,
// the ball normal under the image point and the reflected direction are, in the probe
// frame (v = the view ray's direction, n the outward normal where it meets the ball):
//   orthographic:  v = +X,  n = (-sqrt(1 - rho^2), -a, b),  r = v - 2 (v.n) n
//   perspective :  the camera sits at distance d (ball radii) from the ball centre on -X,
//                  its principal point at the ball's image centre; the silhouette's
//                  half-angle is alpha = asin(1/d), so the ray through (a, b) is
//                  v = normalize(1, -a tan(alpha), b tan(alpha)), intersected with the
//                  ball (nearest root) to get n, then r = v - 2 (v.n) n.
// The world direction is world_from_probe * r. The angle psi between r and -X (the
// "reflection angle") runs from 0 at the centre to 180 deg at the rim (orthographic;
// psi = 2 asin(rho)) or 180 deg - alpha (perspective: the rim reflects the grazing ray).
//
// Inverse (world direction -> image point):
//   orthographic:  n = normalize(r - v) (since v - r = 2 (v.n) n with v.n < 0), then
//                  a = -n.y, b = n.z. Undefined only at r = +X exactly.
//   perspective :  the view ray, the normal and r all lie in the plane through the
//                  camera axis and r, so the hit point is P = cos(g) (-X) + sin(g) u on
//                  the great circle through -X towards r (u = r's part orthogonal to X,
//                  normalised). psi(g) rises monotonically from 0 at g = 0 to
//                  180 deg - alpha at the rim g = acos(1/d); we solve psi(g) = psi(r) by
//                  Newton's method (finite-difference slope) safeguarded by bisection in
//                  [0, acos(1/d)], starting from the orthographic g = psi/2, to 1e-13 rad.
//                  Directions with psi >= 180 deg - alpha are not seen (nullopt).
//
// Reflectivity: a chrome ball reflects ~ 60-70 %. Values are divided by `reflectivity`,
// or with `fresnel` by Schlick's F(cos i) = F0 + (1 - F0)(1 - cos i)^5 with F0 =
// reflectivity (rising to 1 at grazing incidence), cos i = -v.n at the hit point.
//
// All user-fixable failures throw lp::InputError with a one-line message.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>

#include "core/envmap.h"
#include "core/image_io.h"
#include "core/vec3.h"
#include "probe/remap.h"

namespace lp {

// The ball's silhouette in the image: centre and radius in pixels.
struct BallInImage {
  double cx = 0, cy = 0, radius_px = 0;
};

struct MirrorBallCamera {
  // Camera distance from the ball centre in ball radii (> 1); nullopt = orthographic.
  std::optional<double> distance_in_radii;
  // Alternatively the camera's horizontal field of view (degrees, over the image width):
  // the distance follows from the ball's radius in pixels, d = sqrt(1 + (f / R)^2),
  // f = (W / 2) / tan(fov / 2). Give at most one of the two.
  std::optional<double> fov_deg;
  // Rotation applied after the default frame (tilt, azimuth offset): world = M * probe.
  Mat3 world_from_probe{};
  // Reflectivity at normal incidence in (0, 1]; chrome is ~ 0.6-0.7.
  double reflectivity = 1.0;
  // Schlick's Fresnel term rising from `reflectivity` to 1 at grazing incidence.
  bool fresnel = false;
};

// The mapping of one ball in one image, with the camera's distance resolved.
class MirrorBallProjection {
 public:
  // image_width is needed only with fov_deg. Throws InputError on a non-positive radius,
  // a distance <= 1, a field of view outside (0, 180), both distance and field of view,
  // a reflectivity outside (0, 1], or a world_from_probe that is not a rotation.
  MirrorBallProjection(const BallInImage& ball, const MirrorBallCamera& camera, int image_width = 0);

  bool orthographic() const { return !distance_; }
  // Camera distance in ball radii; +inf for orthographic.
  double distance_in_radii() const;
  // Largest reflection angle psi the ball shows (pi orthographic, pi - asin(1/d) perspective).
  double max_reflection_angle() const;

  struct Hit {
    Vec3 direction;        // world direction seen at the image point (unit)
    double cos_incidence;  // -v.n at the hit point, in [0, 1]
  };
  // The world direction seen at image point (x, y); nullopt off the disc.
  std::optional<Hit> hit(double x, double y) const;
  // The image point (x, y) where a world direction is seen; nullopt where the ball does
  // not show it (r = +X orthographic; psi >= max_reflection_angle() perspective).
  std::optional<std::array<double, 2>> image_point(Vec3 world_direction) const;
  // Reflection angle psi (radians) of a world direction: angle between it, taken into
  // the probe frame, and -X.
  double reflection_angle(Vec3 world_direction) const;
  // Reflectivity at the given incidence (the factor the ball multiplies radiance by).
  double reflectivity(double cos_incidence) const;

  const BallInImage& ball() const { return ball_; }

 private:
  BallInImage ball_;
  MirrorBallCamera camera_;
  std::optional<double> distance_;
  double tan_alpha_ = 0;
  Mat3 probe_from_world_{};
};

// ---------------------------------------------------------------------------------------
// Detection.
//
// Method (region contrast, multi-scale, then the silhouette): feature images per pyramid
// level (factors 1, 2, 4, ... down to <= 64 px): compressed colour c / (c + mean
// luminance), 3 x 3 median-filtered against speckle, and the log of local texture energy
// (the residual of a 3 x 3 median, blurred), each channel divided by its own fluctuation
// scale (median |difference| of pixels 2 apart). A circle's contrast per angle is the
// largest channel difference between thin annuli 1-3 level px inside and outside; its
// score is R times the mean over seen angles of a soft support (unseen angles, outside
// the image or on invalid pixels, count as the mean; circles less than half seen fade
// out). Exhaustive search over centre and radius on the coarsest level, the
// best 8 local maxima refined level by level (+-2 level px, parabolic sub-step). Each is
// then fitted to its silhouette on the linear image (probe/ball_rim_fit.h: edges along
// rays, steps from dark to darker that stand clear of the noise counted as well, half-rim
// and outermost-edge hypotheses with circles enclosed by another dropped, against a rim
// that is dark on a dark background, a Tukey-weighted circle fit, then each ray's edge
// placed by area); the one whose rim agrees with
// the edges along the longest arc wins (texture and round features of a background agree
// along little of it); the region answer stands when no fit agrees along half the rim
// (report.subpixel false). Precision: docs/probes.md "Finding the ball".
// Confidence: the share of seen angles whose contrast is >= 3 (at the <= 128 px level):
// ~0.1-0.2 on uniform noise, 0.84-0.87 on the kartik photos, 1 on clean renders.
// Below `min_confidence` -> InputError "no ball found". Invalid pixels (RgbImage::valid)
// are never looked at.
// Cut: the share of the circle's circumference outside the image [0, W] x [0, H]; above
// `max_cut_fraction` -> InputError "ball cut by the image border". The default 0.3
// admits tight crops where the ball touches or slightly overflows two opposite sides
// (6-9 % on the kartik photos); a ball more than 30 % hidden leaves too short an arc
// to pin the radius down.
struct FindBallOptions {
  // Radius search range as fractions of min(W, H) (the radius may exceed half of it
  // when the ball overflows the crop).
  double min_radius_fraction = 0.1;
  double max_radius_fraction = 0.75;
  int rays = 360;
  double max_cut_fraction = 0.3;
  double min_confidence = 0.5;
  // A smaller ball holds under ~200 pixels: no map comes from it, and in a 64x32 preview of
  // a map (no ball at all) a 2.5 px "ball" was found and unwrapped with exit 0.
  double min_radius_px = 8;
  // Skips the Hough search and refines this guess (and the inscribed circle).
  std::optional<BallInImage> initial_guess;
  // With initial_guess: how far (px) the ball may be from it. The guess is refined only on
  // the pyramid levels whose local search (+-2 of their pixels) reaches no further than
  // this, so that a good guess is not carried off to a circle that scores better on the
  // coarse levels (a 400 px city ball moved to a circle 15 px larger). 0: every level.
  double initial_guess_reach_px = 0;
};

struct FindBallReport {
  double confidence = 0;    // as above, in [0, 1]
  double cut_fraction = 0;  // share of circumference outside the image
  double rms_residual_px = 0;  // of the final fit's inliers
  int edge_points = 0;         // inliers of the final fit
  // Whether the silhouette fit was kept (else the region answer stands, good to a few
  // pixels, and the three numbers above and below are 0).
  bool subpixel = false;
  // The fit's standard errors (px): of the centre (the larger axis of its 1-sigma ellipse)
  // and of the radius (probe/ball_rim_fit.h). sigma_* cover more than the noise: the larger
  // of the fit's covariance and the spread over the rim's sectors, with the difference
  // between the two competing circles of the last step (the one-step silhouette, the outer
  // edge of a band at the rim) in quadrature; noise_sigma_* are the covariance alone.
  double sigma_centre_px = 0, sigma_radius_px = 0;
  double noise_sigma_centre_px = 0, noise_sigma_radius_px = 0;
  // Share of the rim in view along which the fitted circle has an edge (within 0.5 px):
  // clean renders 0.7-1; about 0.5 where half the rim is dark on a dark background.
  double rim_agreement = 0;
  // A circle agreeing along an arc inside the one reported was set aside as a border in
  // the reflection (probe/ball_rim_fit.h): some of the rim has no contrast.
  bool inner_rim_dropped = false;
};

BallInImage find_ball(const RgbImage& image, const FindBallOptions& options = {},
                      FindBallReport* report = nullptr);

// Below this rim agreement a fit rests on part of the rim only (half the rim dark on dark:
// about 0.5; clean renders 0.7-1).
constexpr double kPartialRimAgreement = 0.6;

// One line saying why the ball may be off by more than the report's sigmas (no sub-pixel
// fit; edges along less than kPartialRimAgreement of the rim), or empty.
std::string ball_fit_warning(const FindBallReport& report);

// ---------------------------------------------------------------------------------------
// Unwrapping.

struct MirrorBallRemapOptions {
  // Half-angle (deg) of the cone around the blind spot (the direction behind the ball,
  // probe +X) left invalid: reflections there come from the ball's rim, where one pixel
  // spans tens of degrees and the edge blends with the background.
  double blind_spot_deg = 15;
  // Source points closer than this to the fitted rim are invalid (the bilinear footprint
  // would reach background pixels).
  double rim_margin_px = 1.0;
};

// Per pixel of an env map of `layout` and size (healpix: width = nside) the image point
// where its centre direction is seen. NaN where the direction is in the blind spot, not
// shown by the ball, within rim_margin_px of the rim, or outside the image
// [0, W] x [0, H]. Table size = the map's width x height (healpix: 12 nside^2 x 1).
RemapTable mirror_ball_remap(const BallInImage& ball, const MirrorBallCamera& camera, int image_width,
                             int image_height, Layout layout, int width, int height,
                             const MirrorBallRemapOptions& options = {});

struct UnwrapOptions {
  double blind_spot_deg = 15;
  double rim_margin_px = 1.0;
  // k x k sub-samples per output pixel, nested sub-pixels of equal-size grid cells
  // (latlong/hemisphere: the k-times finer grid; healpix: NESTED children, k rounded up
  // to a power of two), averaged in radiance weighted by exact solid angle over the
  // valid ones. 0 = automatic: about one sub-sample per source pixel at the ball's
  // centre, k = ceil(output pixel angle / (2 / R)), in [1, 8].
  int samples_per_edge = 0;
  // An output pixel is valid when at least this share of its solid angle is covered by
  // valid sub-samples.
  double min_valid_fraction = 0.5;
  // Divide by the ball's reflectivity (MirrorBallCamera::reflectivity / fresnel).
  bool compensate_reflectivity = true;
  // Fill invalid pixels smoothly from valid ones (push-pull: a pyramid of valid-weighted
  // 2 x 2 averages, then each invalid pixel takes the bilinear upsampling of the next
  // coarser level; latlong wraps in azimuth; healpix uses the NESTED parent's value).
  // The validity mask is kept: filled pixels stay invalid, so power over the valid
  // region is unchanged, and the filled share is reported.
  bool fill = false;
};

struct UnwrapReport {
  int samples_per_edge = 0;
  double valid_solid_angle_fraction = 0;  // of the layout's solid angle
  // Luminance power in filled (invalid) pixels over the total luminance power including
  // them; 0 without fill.
  double fill_power_share = 0;
};

// The ball's image as an env map in the world frame with the validity mask set (never
// zeros that look like darkness). Units copied from the image. Throws InputError on an
// empty image or a bad camera/ball.
EnvMap unwrap_mirror_ball(const RgbImage& image, const BallInImage& ball, const MirrorBallCamera& camera,
                          Layout layout, int width, int height, const UnwrapOptions& options = {},
                          UnwrapReport* report = nullptr);

}  // namespace lp
