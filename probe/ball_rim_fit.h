// The last step of find_ball (probe/mirror_ball.h): the ball's silhouette to a fraction of
// a pixel, from a centre and radius good to a few pixels.
//
// Along rays from the centre, edges are the local maxima of the radial derivative of the
// linear image (summed over the colour channels), placed by a parabola. Per ray the
// outermost edge within a window around the current circle is taken, among those at
// least 10 % as strong as the median ray's strongest: the silhouette is the ball's outer
// boundary, while its rim reflects the whole scene behind it squeezed into a few pixels,
// rings just inside that a strongest-edge rule would follow. A circle is fitted to them
// by Gauss-Newton with Tukey biweights (scale from the residuals' MAD) times the edge's
// strength relative to the median edge, capped at 1, so that a rim dark against a dark
// background counts little and a blinding arc no more than any other edge. A step too weak
// for that floor still counts when one side is less than half the other and it stands
// clear of the image's noise (a dark reflection at the rim against a dark background):
// per ray it blocks the stronger border of the dark reflection further in. Windows shrink 3, 2, 1.5, 1 px as the circle settles.
//
// Uncertainty: the weighted least-squares covariance s^2 (J^T W J)^-1 with
// s^2 = sum w r^2 / (sum w - 3), inflated by the rays' correlation (neighbouring rays
// closer than 2 px share the smoothed pixels they sample: variance times 2 px / spacing).
#pragma once

#include <opencv2/core.hpp>

#include <vector>

#include "probe/mirror_ball.h"

namespace lp {

struct RimEdge {
  double x, y, strength;
  // |inner - outer| / max(inner, outer) of the channel sums 1.5 px either side: 1 for a
  // step from nothing, whatever its height.
  double rel = 0;
};

// Bilinear sample of a 3-channel float image at (x, y), pixel centres at +0.5; the
// caller keeps (x, y) within [0.5, W - 0.5] x [0.5, H - 0.5].
cv::Vec3f bilinear3(const cv::Mat& img, double x, double y);

// Edges along the ray at angle theta from (cx, cy) within radii [r_lo, r_hi], strongest
// first (at most `keep`); empty when the band leaves the image.
std::vector<RimEdge> radial_edges(const cv::Mat& img, double cx, double cy, double theta, double r_lo, double r_hi,
                                  int keep, double step = 0.25);

struct RimFit {
  BallInImage ball;
  double sigma_centre_px = 0, sigma_radius_px = 0;  // as find_ball reports them
  double noise_sigma_centre_px = 0, noise_sigma_radius_px = 0;  // the fit's covariance alone
  double rms_px = 0;    // weighted RMS residual of the inliers
  int inliers = 0;      // rays whose edge has a non-zero final weight
  // Share of the rays in view (inside the image, on valid pixels) whose outermost edge
  // within 1 px of the circle lies within 0.5 px of it.
  double agreement = 0;
  // A hypothesis agreeing along an arc lay inside this one by more than a pixel and was
  // dropped (the border of a dark reflection at the rim): the rim here may have arcs
  // without contrast.
  bool inner_rim_dropped = false;
  bool ok = false;      // false: too few edges, or the fit ran away (> 2 windows)
};

// `linear`: CV_32FC3, values proportional to radiance; `valid8`: CV_8U (1 valid) of the
// same size, or empty. Rays whose band touches an invalid pixel are skipped.
// `edge_noise`: the edge strength (1 px difference of `smooth`, summed over the channels)
// that noise alone reaches (edge_noise_level): weaker steps never count, however
// dark one side is.
RimFit fit_rim(const cv::Mat& smooth, const cv::Mat& linear, const cv::Mat& valid8, const BallInImage& start, int rays,
               double edge_noise);

// The rim fit's circle refined on the silhouette by pixel coverage (probe/ball_rim_coverage.h:
// one edge per arc of about 8 px, the circle fitted to them as above, up to three passes
// while it moves less than 1 px; the blur, 0, 0.5 or 1 px, is the one whose model leaves
// the least residual at the start). A second circle takes, on the arcs that show one, the
// outer edge of a band of the rim's reflection up to 3 px wide instead (passes may move it
// 2.5 px); the circle that more arcs agree with (one of their edges within 0.5 px) wins,
// the first on a tie, unless the banded circle encloses the other by 0.5 px and agrees with
// half its arcs (the silhouette is the outer boundary). Where the winner agrees with fewer
// than half its arcs (trapped: the rim fit off by more than the 0.75 px reach) both are
// refined again from a first pass of 2 px reach, and that winner replaces it when more arcs
// agree with it by 2 sqrt(arcs). Last, arcs whose edge lies more than 0.5 px inside the
// winner are dropped and it is refitted on the rest until none drop out (the silhouette is
// the outer boundary; a stretch of the rim without contrast at the silhouette holds a border
// further in, which the Tukey scale from the MAD averaged in). `rim` unchanged when it is
// not ok or fewer than 12 arcs give an edge. noise_sigma_*: this fit's covariance (the arcs
// share no pixels); sigma_* also cover the spread over the rim's eight sectors (a
// delete-a-sector jackknife) or over its eight halves (each refitted alone), where larger,
// and the difference between the two circles, added in quadrature.
RimFit refine_rim_by_coverage(const cv::Mat& linear, const cv::Mat& valid8, const RimFit& rim, double edge_noise);

// The edge strength noise alone reaches in `smooth` (CV_32FC3): 7 x the 5th percentile of
// the 1 px horizontal differences (summed over channels) on valid pixels. Flat regions
// have none, so noise sets the low percentiles and texture the upper ones; for Gaussian
// noise 7 x the 5th percentile is beyond the 99.9th (a sum of three half-normals: p5
// 0.87 sigma, p99.9 6.3 sigma).
double edge_noise_level(const cv::Mat& smooth, const cv::Mat& valid8);

}  // namespace lp
