// Stage "seed" of a geometric calibration: an initial guess (intrinsics + one pose per view)
// for each candidate model, from OpenCV's closed-form calibrators, that the solve stage
// (calibration_solve.h) refines. mrcal's C API does no seeding, so every mrcal solve starts
// from one of these and is a deterministic function of it.
//
//   Kannala-Brandt   cv::fisheye::calibrate on every inlier corner; when it fails, on the
//                    corners near the image centre (cv::fisheye cannot image rays near 90
//                    deg); then every view re-posed under the seed (PnP on the rays + pixel
//                    refinement), keeping whichever pose fits the view better.
//   Mei              with SolveOptions::mei_from_kannala_brandt, where the Kannala-Brandt fit
//                    of the same views is within kMeiFromKannalaBrandtRmsPx: its core and
//                    poses, and the xi, focal length and k1 k2 closest to its radial profile
//                    over the corners' angles; else xi = 1, the image's centre, no
//                    distortion and the generalised focal length that poses a few views best
//                    (mei_unit_xi_seed); cv::omnidir::calibrate only where that cannot pose
//                    every view (it drops views its initialisation cannot use: those are
//                    posed by PnP), then re-posed as Kannala-Brandt.
//   pinhole, plumb_bob, rational (OpenCV5, OpenCV8)
//                    cv::calibrateCamera with the model's flags, each step solved by LU
//                    (CALIB_USE_LU: 3-5x faster than its default SVD, and reproducible).
//   stereographic    the core (fx fy cx cy) and poses of a Kannala-Brandt fit (any field
//                    of view), else of a pinhole fit.
//   splined          a zero spline over a stereographic fit (exactly that model), its field
//                    of view the widest horizontal angle of the image under it, with a margin.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "calib/calibration_problem.h"
#include "calib/lens_model.h"

namespace lp {

// Mei's seed comes from Kannala-Brandt (SolveOptions::mei_from_kannala_brandt) where that fits
// the corners within this RMS (px) and sees them all within this angle of the axis (deg):
// on such a narrow field xi is barely observable and cv::omnidir walks its valley (300
// iterations and a 160-library plugin on the stereo set). On wider lenses the fits from the
// two seeds end at different points of Mei's flat minimum, and cv::omnidir's repeat better
// between halves (six pairs of halves of fisheye1: Mei fixed 0.741 px against 0.780 from
// Kannala-Brandt), so they keep it. 45 deg, not the selection's 60: a half of the shared
// 190-degree set seen to 58 deg took the Kannala-Brandt seed at 60 and its pick changed
// (docs/calibration.md, "Stop 37: the floor was half a colour map"); the narrow shared sets
// reach 30-41.
inline constexpr double kMeiFromKannalaBrandtRmsPx = 1.0;
// The stereographic seed takes Mei's core and poses where that fit is within this RMS of the
// views (it fits the lens), else Kannala-Brandt's (seed_candidate).
inline constexpr double kStereographicSeedRmsPx = 1.5;
inline constexpr double kMeiFromKannalaBrandtFieldDeg = 45;

struct SeedOptions {
  // Kannala-Brandt fallback: corners within this fraction of the image's short side from
  // the centre (where cv::fisheye's model, which cannot reach 90 deg, still holds).
  double kb_central_radius = 0.45;
  // Kannala-Brandt's seed: at most this many iterations of cv::fisheye's own solver. It is a
  // seed, which the Ceres refinement takes to convergence, and cv::fisheye re-solves every
  // view's homography and extrinsics in each iteration (~65 ms an iteration on 32 views).
  // Refined, the fits are one minimum whether cv::fisheye stops at 200, 30 or 5: at 200 vs 30
  // the same RMS to 1e-12 px, also where cv::fisheye, run to 200 on every corner, gives up
  // and the seed falls back to the central ones; at 30 vs 5 every report of the seven shared
  // sets and of the synthetic 8-64 views agrees to 6e-6 relative (3 still does). A narrow lens
  // used all 30 (stereo: 143 ms of CPU for its 13 views, 49 at 5). On a mirror, where
  // Kannala-Brandt cannot fit, 5 may return a fit that is then screened out where 30 threw.
  int fisheye_iterations = 5;
  // The splined model's field of view: the stereographic seed's horizontal field times this
  // margin (so that the image's edge columns fall inside the spline's domain).
  double spline_fov_margin = 1.05;
  // pinhole, plumb_bob, rational, Mei and Kannala-Brandt on at least 2 x sample_views views:
  // the OpenCV seed and its refinement run on sample_views of them, evenly spaced, and the fit
  // on every view is refined from there (the other views posed under it). cv::calibrateCamera
  // and cv::omnidir::calibrate solve a dense system in every pose each iteration, cubic in the
  // views: on 64 views of the 190 deg synthetic lens they were 35 % of the selection's
  // time, most of it in dense matrix products and inverses. cv::fisheye re-solves every
  // view's homography in each iteration: 1.1 s on those 64 views, a third of the forced
  // command. 0: always on every view.
  // (CandidateSolver applies it; seed_candidate itself seeds on the views given.)
  int sample_views = 16;
  // Mei where Kannala-Brandt does not seed it: the unit-xi search (mei_unit_xi_seed), with
  // cv::omnidir only where that cannot pose every view; false: cv::omnidir first, as before.
  bool mei_unit_xi = true;
};

// What a seed is, beside the fit (ModelFit::solver names the OpenCV call).
struct SeedReport {
  ModelFit fit;
  bool central_corners_only = false;  // Kannala-Brandt: the fallback on the central corners ran
  int views_reposed = 0;              // views whose OpenCV pose a PnP pose replaced
};

// The solved fit of another candidate on the same views (the stereographic seed needs the
// Kannala-Brandt or pinhole fit, the splined one the stereographic fit).
using SolvedFit = std::function<const ModelFit&(LensType)>;

// The seed of candidate `type` on `views` (a calibration candidate: lens_model.h
// candidate_lens_type). Not ok, with the reason, when the OpenCV call fails or diverges or
// the model needs mrcal and problem.solve.use_mrcal is false.
SeedReport seed_candidate(const CalibrationProblem& problem, const ViewSubset& views, LensType type,
                          const SolvedFit& solved, const SeedOptions& options = {});

// The OpenCV calls themselves, as OpenCV returns them (the peers of eval calib use them
// alone). cv::fisheye::calibrate over the inlier corners `use` accepts: views with fewer than
// 6 such corners get no pose (has_pose[i] = 0); at most max_iterations of its own solver.
ModelFit opencv_fisheye(const CalibrationProblem& problem, const ViewSubset& views,
                        const std::function<bool(const std::array<double, 2>&)>& use, std::vector<char>* has_pose,
                        int max_iterations = 200);
// cv::calibrateCamera with the flags of pinhole, OpenCV5 (plumb_bob) or OpenCV8 (rational).
// lu_steps: each Levenberg-Marquardt step solved by LU (the seeds); false keeps OpenCV's own
// default, SVD, for the peer calibration that stands for OpenCV as a user runs it
// (calibrate_opencv_alone).
ModelFit opencv_calibrate_camera(const CalibrationProblem& problem, const ViewSubset& views, LensType type,
                                 bool lu_steps = true);
// cv::omnidir::calibrate (Mei); views it drops have has_pose[i] = 0.
// max_iterations: cv::omnidir's own Levenberg-Marquardt; a seed needs few (seed_mei: 30),
// OpenCV run alone as the peer of `eval calib` runs to convergence (300).
ModelFit opencv_omnidir(const CalibrationProblem& problem, const ViewSubset& views, std::vector<char>* has_pose,
                        int max_iterations = 300);

// Mei's seed without cv::omnidir: xi = 1 (the unified model of a parabolic mirror, which
// cv::omnidir's own initialisation assumes too), the image's centre, no distortion, and the
// generalised focal length gamma whose poses fit `probe_views` evenly spaced views best (a
// pixel radius r is gamma tan(theta / 2) at xi = 1): a grid of factor 2 over 0.2-16 times the
// probe corners' largest radius from the centre (150 deg to 10 deg off the axis), then a
// golden-section search within a grid step of its best. Every view posed under it. Not ok
// when some view cannot be posed. Written here rather than taken from cv::omnidir because
// that plugin loads 160 libraries (its highgui's Qt, GStreamer, ffmpeg): 85 ms on the
// automatic choice's critical path, where this search takes ~15 ms and, refined, reaches
// cv::omnidir's minimum on every shared set (within 1e-5 relative) but one half of the
// VMRImage mirror, where it finds a better one (held-out RMS 0.378 -> 0.355 px).
ModelFit mei_unit_xi_seed(const CalibrationProblem& problem, const ViewSubset& views, size_t probe_views = 4);

// The seed rounded to well above cv::calibrateCamera's run-to-run noise (1e-3 px core,
// 1e-5 per distortion coefficient, 1e-6 rad, 1e-3 mm): what mrcal's polish starts from, so
// that the polished model is the same on every run.
ModelFit rounded_seed(const ModelFit& fit);

}  // namespace lp
