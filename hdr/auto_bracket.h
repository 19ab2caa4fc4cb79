// Auto-bracketing: the fewest exposure times, within a camera's limits, whose union sees
// every pixel of a metered scene inside the response's usable range, and a planner that
// follows the scene with hysteresis (issue 20 item 1).
//
// Units. The response (hdr/response.h) maps code z to g(z) = ln(E t); a merged bracket
// gives radiance L = exp(g(z)) / t in the same relative units. A pixel of radiance L seen
// at exposure time t therefore reads the code z with exp(g(z)) = L t.
//
// Target SNR, as a coverage rule. A pixel is COVERED by a bracket when at least one of its
// exposures reads it at a code in [min_code, max_code] of full scale in every channel
// that matters (the pixel's brightest channel, see below):
//   - min_code (default 0.1) is the noise floor. At 0.1 of full scale a linear sensor
//     with a 10 000 e- well has a shot-noise SNR of sqrt(1000) = 32 and an 8-bit code
//     still has 25 levels (quantisation SNR 87); the merge's hat weight there is 0.17 of
//     its peak, so the frame counts. Below it a reading is mostly noise and quantisation.
//   - max_code (default 0.95) is below the merge's saturation threshold (0.98,
//     hdr/merge.h) by enough that shot noise does not push a covered pixel into clipping.
// In exposure terms an exposure t covers radiance [x_low / t, x_high / t] with
// x_low = exp(g(min_code)) and x_high = exp(g(max_code)) (usable_exposure_window), i.e. a
// window of x_high / x_low in radiance (9.3x, 3.2 stops, for an 8-bit linear response).
// Consecutive exposures of a plan are at most window / overlap apart, so that their
// windows overlap and every pixel in between is covered by one of them.
//
// Which pixels must be covered. Each valid pixel counts with its brightest channel
// (max(R, G, B)): that channel clips first, and it carries the pixel's signal. The
// brightest pixels are never left out: on a light probe they are the lights (a sun of a
// few pixels holds most of the power). The darkest `dark_fraction` of the pixels may be
// left under the floor (default 1 %: masked-looking black corners, a few dead pixels),
// so that they do not cost a whole exposure each.
//
// A metered scene is only known within the bracket that measured it: a pixel clipped
// in the shortest exposure is only a lower bound (the merge gives it the shortest frame's
// estimate), a pixel black in the longest an upper bound. The planner assumes such an end
// extends `probe_factor` (16x, 4 stops) further and re-plans from there, so that a
// clipped sun is found in a few brackets instead of one stop at a time.
//
// Camera limits. Times are clamped to [min_seconds, max_seconds], at most max_exposures.
// When a scene needs more than the camera allows, the bright end is kept (it holds the
// lights) and the dark end is given up; the plan says which end is not covered and why.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/image_io.h"
#include "hdr/response.h"

namespace lp {

// The radiance x t that the usable codes stand for (see above). Computed per channel and
// the narrowest taken (the largest low end, the smallest high end). Throws InputError when
// the response has an unusable shape or min_code >= max_code, or either is outside (0, 1).
struct ExposureWindow {
  double x_low = 0;   // exp(g(min_code))
  double x_high = 0;  // exp(g(max_code))
  double min_code = 0.1, max_code = 0.95;
  double x_clipped = 0;  // exp(g(clipped_code)): a reading at or above this is clipped
  double x_black = 0;    // exp(g(black_code)): a reading at or below this is black
};
struct CoverageCodes {
  double min_code = 0.1;      // noise floor (see above)
  double max_code = 0.95;     // below clipping (see above)
  // Readings taken as clipped / black when metering: the merge's thresholds (0.98, 0.02)
  // less a margin, because unwrapping blends a clipped pixel with its neighbours.
  double clipped_code = 0.97;
  double black_code = 0.03;
};
ExposureWindow usable_exposure_window(const CameraResponse& response, const CoverageCodes& codes = {});

// What the camera can do.
struct ExposureLimits {
  double min_seconds = 1e-5;  // shortest exposure time
  double max_seconds = 1.0;   // longest exposure time
  int max_exposures = 7;      // frames in one bracket
  int min_exposures = 1;      // 2 where only brackets can be fused (the live pipeline)
};

// The scene as metered: one value per valid pixel, its brightest channel, in the
// response's relative radiance (the last fused map before any photometric scale).
// `exposure_seconds`: the bracket it was fused from (to tell clipped and black pixels);
// empty when the values are exact (a synthetic scene, a radiance map).
struct MeteredScene {
  std::vector<float> radiance;
  std::vector<double> exposure_seconds;
};
// A map's or image's valid pixels as a MeteredScene; pixels that are not finite or not
// positive are left out (a black pixel has no radiance to plan for).
MeteredScene meter_image(const RgbImage& radiance, std::vector<double> exposure_seconds = {});
// One frame's codes metered through the response (L = exp(g(z)) / t), for a bracket that
// could not be fused because no pixel was well exposed in any frame: its shortest frame
// when that one is not all black, else its longest. The clipped (black) pixels then tell
// the planner to look further, so that a first bracket far off the scene still leads
// somewhere. InputError when the bracket has no frames or its sizes differ.
MeteredScene meter_unfusable_bracket(const std::vector<RgbImage>& frames, const std::vector<double>& exposure_seconds,
                                     const CameraResponse& response, const ExposureWindow& window);

struct AutoBracketOptions {
  CoverageCodes codes;
  double dark_fraction = 0.01;  // darkest pixels that may stay under the floor
  double overlap = 1.5;         // consecutive windows overlap by this factor (>= 1)
  // A new plan covers [low / headroom, high * headroom]: 1.5 stops at each end.
  double headroom = 2.83;
  // Hysteresis: re-plan when the scene comes within `replan_margin` (half a stop) of the
  // edge of what the current bracket covers (or past it), and shrink to fewer exposures
  // only when the smaller plan would still have headroom * replan_margin. With
  // 1 < replan_margin < headroom a scene must move by headroom / replan_margin (2x, one
  // stop) before a steady plan changes, and a new plan never triggers the opposite change
  // at once (its own headroom is beyond the margin, and a wider plan never has fewer
  // exposures).
  double replan_margin = 1.41;
  double probe_factor = 16;     // a clipped (black) end is assumed this much further out
};

// Which end of the scene a plan leaves uncovered because of the camera, and why.
enum class BracketLimit { None, BrightShortest, DarkLongest, DarkMaxExposures };
const char* to_string(BracketLimit limit);  // "none", "bright: shortest exposure", ...

struct BracketPlan {
  std::vector<double> exposure_seconds;  // ascending
  double scene_low = 0, scene_high = 0;  // radiance planned for (dark quantile, max, probes applied)
  double scene_stops = 0;                // log2(scene_high / scene_low)
  bool bright_clipped_in_meter = false;  // the metered max was clipped: scene_high is a guess
  bool dark_black_in_meter = false;      // the metered dark end was black: scene_low is a guess
  double cover_low = 0, cover_high = 0;  // radiance the bracket covers (window through its times)
  double covered_fraction = 0;           // of the metered pixels (known inside coverage)
  BracketLimit limit = BracketLimit::None;  // the first end given up (bright before dark)
  std::string limit_text;                   // every end given up, with the camera's limit ("; ...")
  std::string reason;                    // one line: the range, the plan, what is not covered
};

// The fewest exposures covering the metered scene with `headroom` at both ends (see
// above), spaced evenly in log time. InputError on an empty scene, bad options or limits.
BracketPlan plan_bracket(const MeteredScene& scene, const ExposureWindow& window, const ExposureLimits& limits,
                         const AutoBracketOptions& options = {}, double headroom = -1 /* options.headroom */);

// The plan followed over time, with the hysteresis of AutoBracketOptions::replan_margin.
class AutoBracketPlanner {
 public:
  AutoBracketPlanner(ExposureWindow window, ExposureLimits limits, AutoBracketOptions options = {});
  // Meters the scene and returns true when the plan changed (always for the first scene).
  bool update(const MeteredScene& scene);
  const BracketPlan& plan() const { return plan_; }
  // Why the last update kept or changed the plan ("first plan", "bright end within 2x of
  // clipping", "range shrank: 2 exposures suffice", "steady").
  const std::string& last_decision() const { return decision_; }
  uint64_t changes() const { return changes_; }  // plan changes after the first
  bool has_plan() const { return !plan_.exposure_seconds.empty(); }

 private:
  ExposureWindow window_;
  ExposureLimits limits_;
  AutoBracketOptions options_;
  BracketPlan plan_;
  std::string decision_;
  uint64_t changes_ = 0;
};

}  // namespace lp
