// Stabilising a probe in video: the image circle of a fisheye (or any bright disc on
// black, e.g. a mirror ball's outline given per-frame estimates) is found in each
// frame and its track smoothed, so that the unwrap does not shake with detection noise.
// Kronander et al. ("Real-time video based lighting using GPU raytracing") stabilise
// their probe frames before the latlong mapping, "removing vibrations in the light
// probe relative to the camera"; Havran et al. 2005 §5 convert each fisheye frame to
// a 360 x 90 polar map with one fixed calibration. Here the probe is assumed fixed
// relative to the camera: the true circle moves only by slow drift (thermal, mount
// creep), and frame-to-frame changes of the estimate are noise.
//
// Coordinates are OpenCV pixel coordinates (pixel centres at integers), as
// FisheyeModel::cx / cy.
#pragma once

#include <vector>

#include "core/image_io.h"

namespace lp {

struct CircleTrack {
  std::vector<double> cx, cy, r;  // one entry per frame; the three the same length
};

struct SmoothOptions {
  // true: a fixed probe without drift: every frame gets the track's median
  // (component-wise), the most robust estimate there is.
  bool static_probe = false;
  // Otherwise: a centred moving median over `median_window` frames (odd; shrinks at
  // the ends of the track), which ignores outlier frames (missed detections, a hand
  // over the lens), then a Gaussian of `gaussian_sigma` frames (0 = none) that removes
  // the median's residual steps (defaults: 4 s at 30 fps; 1 px per-axis noise -> 0.14 px
  // RMS centre error). Drift slower than ~window frames is followed. The
  // smoothed value of frame i uses frames up to i + window / 2 + 3 sigma: live use
  // delays by that many frames, or uses static_probe.
  int median_window = 121;
  double gaussian_sigma = 20;
};

// Throws InputError when the three vectors differ in length, or median_window < 1.
CircleTrack smooth_track(const CircleTrack& raw, const SmoothOptions& options = {});

// Frame-to-frame jitter of the centre, px: sqrt(mean over i of |c_i - c_{i-1}|^2 / 2).
// For independent per-frame noise of standard deviation s per axis this estimates
// s * sqrt(2) (the 2-D RMS), and slow drift adds almost nothing. 0 for < 2 frames.
double residual_jitter_px(const CircleTrack& track);

struct ImageCircle {
  double cx = 0, cy = 0, r = 0;
  double rms_residual_px = 0;  // RMS distance of the boundary points from the fitted circle
  int boundary_points = 0;     // points used in the final fit
};

struct FindCircleOptions {
  int rays = 360;  // boundary samples, one per ray from the centre
  // A pixel is "lit" above dark + threshold * (bright - dark), where dark and bright
  // are the 1st and 90th luminance percentiles. The edge itself is then located on each
  // ray at the half level between the local inside and outside values (sub-pixel).
  double threshold = 0.1;
};

// The fisheye's image circle (bright disc on black): threshold, centroid as a first
// centre, one boundary point per ray at the outermost lit-to-dark crossing (sub-pixel,
// at the local 50 % level), algebraic circle fit with outlier rejection (3 MAD),
// repeated once from the fitted centre. Throws InputError when no disc is found
// (nothing lit, or the lit region touches every image edge so no boundary is seen).
ImageCircle find_image_circle(const RgbImage& image, const FindCircleOptions& options = {});

}  // namespace lp
