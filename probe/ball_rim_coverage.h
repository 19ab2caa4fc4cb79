// The ball's silhouette by pixel coverage: the last step of find_ball (probe/mirror_ball.h),
// after the rim fit (probe/ball_rim_fit.h) has the circle to a few tenths of a pixel.
//
// Why: the rim fit places each ray's edge by area, taking the ball's value 1.5 px inside as
// the value of its last 1.5 px. A mirror ball compresses the cap of directions behind it
// into those pixels: at depth d inside the silhouette it reflects the direction at
// 2 sqrt(2 d / R) rad from the one straight behind it (16 deg at R 150, d 1.5 px), so the
// last 1.5 px show a different part of the scene than the pixel that stands for them, and
// the edge moves by 1.5 px x (their mean - that value) / contrast: 0.1-0.5 px per ray on the
// shared maps, inward or outward with the scene (on the shared maps more often inward: a
// median -0.13 to -0.29 px at R 150 and 400).
//
// How: the rim is cut into arcs about 8 px long. Within an arc the ball's radiance changes
// slowly along the rim (the same depth sees directions a fraction of a degree apart) and
// fast across it, while the circle crosses the arc's pixels at every sub-pixel phase. Each
// pixel is modelled as the mean over its square (8 x 8 points) of the ball inside the
// circle and the background outside:
//   ball(d, t)       = b0 + b1 d + b2 t   (d: depth inside the circle, t: along the rim)
//   background(s, t) = g0 + g1 s + g2 t   (s: distance outside)
// per colour channel, linear given the circle, on the pixels from 1.5 px (+ blur) inside to
// 2.5 px outside it; the pixel's square may be blurred further (`blur_px`). The
// arc's edge is the radius (within +-`reach_px` of the circle) where that least-squares fit
// leaves the least residual: the straddling pixels must be explained by their coverage,
// not by the pixel 1.5 px inside.
// A band at the rim: where the ball reflects a band (dark, say) a few pixels wide along its
// rim, the band's inner border is the stronger step and wins that search, while the
// silhouette is the band's outer edge, which the earlier passes (on an image smoothed by
// 1 px) cannot separate from it when the band is narrower than about 3 px. So beyond each
// arc's edge, on the pixels wholly outside it, a band (constant along the radius) up to
// `band_px` wide followed by the background is tried against the background alone; where
// it wins by an F test the arc has a second, outer edge (coverage_arcs), and the caller
// decides per circle which to believe (refine_rim_by_coverage).
// What it cannot see: content that changes within the last fraction of a pixel (a scene
// textured at the blind spot) is, per arc, indistinguishable from a shifted edge; a model
// with a sqrt(d) term (the reflection's own expansion near the rim) can mimic such a
// sliver and did slightly worse (docs/probes.md).
#pragma once

#include <opencv2/core.hpp>

#include <vector>

#include "probe/ball_rim_fit.h"
#include "probe/mirror_ball.h"

namespace lp {

struct CoverageEdgeOptions {
  double arc_px = 8;      // arc length per edge along the rim
  // Pixels whose centre lies within these of the circle take part. Inside, only the last
  // 1.5 px plus twice the blur: deeper, the reflection holds edges of its own (the border of
  // a dark band at the rim) that a model linear in depth cannot follow and whose residual
  // would pull the edge onto them (whole grid: 157 of 239 within 0.2 px, 136 with 2.5 px),
  // while the blurred ramp must lie inside the band (without the blur term a resampled rim
  // came out 0.39 px too large, BallRegister.ARegisteredRenderHasTheRegisteredGeometry).
  double inner_band_px = 1.5;  // plus 2 x blur_px
  double outer_band_px = 2.5;
  // Gaussian sigma of the blur beyond the pixel's square (lens, demosaicing, resampling):
  // each area point is moved by a fixed normal offset times this.
  double blur_px = 0;
  double reach_px = 0.75; // the edge is searched within this of the circle
  // A band of the rim's reflection up to this wide outside the one-step edge is looked for
  // (0: not): the silhouette is then its outer edge.
  double band_px = 0;
};

// One edge per arc of `c` that lies inside the image on valid pixels (`valid8`: CV_8U, 1
// valid, or empty), at the arc's mid-angle. `strength`: the contrast |ball - background|
// (3-channel norm) half a pixel either side of the edge; `rel`: the channel sums' contrast
// relative to the brighter side. Arcs whose best edge is at the end of the search range are
// left out. `linear`: CV_32FC3, values proportional to radiance.
// `residual` (optional): the sum over the arcs of the least residual found, for comparing
// options on the same circle.
std::vector<RimEdge> coverage_edges(const cv::Mat& linear, const cv::Mat& valid8, const BallInImage& c,
                                    const CoverageEdgeOptions& options = {}, double* residual = nullptr);

// Per arc, its one-step edge (as coverage_edges) and, with `band_px`, the silhouette as the
// outer edge of a band of the rim's reflection beyond it, where the pixels outside the
// one-step edge show one; strength < 0 where there is none. Arcs in the same order as the
// angles, every arc listed.
struct CoverageArc {
  RimEdge step{0, 0, -1}, band{0, 0, -1};
};
std::vector<CoverageArc> coverage_arcs(const cv::Mat& linear, const cv::Mat& valid8, const BallInImage& c,
                                       const CoverageEdgeOptions& options = {}, double* residual = nullptr);

}  // namespace lp
