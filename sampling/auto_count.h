// "Model no more than a scene needs": the smallest light count whose error (core/accuracy.h:
// diffuse, a glossy lobe, shadowed, or the worst of them) is at most a target.
//
// The measure matters: on the procedural scene q2tree reaches 1 % diffuse error with 48
// lights whose glossy s=100 error is 53 %; a renderer with shiny materials asks for
// glossy100 (or worst), and pays for it in lights.
//
// Assumption: the error of a method falls (not necessarily strictly) as n
// grows. It is not exactly monotone for low-discrepancy points, so the search brackets:
// it doubles n until the target is met, then bisects between the last count that missed
// and the first that met it. Where the error is not monotone inside that bracket, the
// answer is a count that meets the target, possibly not the very smallest.
// Cost: about 2 log2(n) samplings and error evaluations instead of n.
#pragma once

#include <string_view>

#include "core/accuracy.h"
#include "sampling/sampler.h"

namespace lp {

// The accuracy measure held under the target (--error-measure).
enum class ErrorMeasure {
  Diffuse,    // irradiance over 256 normals
  Glossy10,   // Phong lobe s = 10
  Glossy100,  // Phong lobe s = 100
  Shadowed,   // diffuse with 60-degree caps occluded (mean over 64 caps)
  Worst,      // the largest of the four
};
std::string_view to_string(ErrorMeasure measure);
// "diffuse", "glossy10", "glossy100", "shadowed", "worst"; InputError naming them otherwise.
ErrorMeasure error_measure_from_string(std::string_view name);
// The cheapest accuracy reference that can score `measure` (diffuse alone skips the lobes
// and the 64 shadowed passes).
AccuracyOptions reference_options_for(ErrorMeasure measure);
// The value of `measure` in `error`, scored against a reference built with `reference`;
// InputError when that reference lacks the measure (no such lobe, shadowed off).
double measured_error(const LightError& error, const AccuracyOptions& reference, ErrorMeasure measure);

struct AutoCountOptions {
  double target_error = 0.01;  // relative RMS of `measure`, e.g. 0.01 = 1 %
  ErrorMeasure measure = ErrorMeasure::Diffuse;
  int min_count = 16;  // q2tree cannot go below its 12 base quads
  int max_count = 16384;  // give up (and report it) above this
};

struct AutoCountResult {
  int count = 0;             // lights returned (q2tree may return up to 2 fewer than asked)
  int requested = 0;         // the n asked of the sampler for them
  double error = 0;          // its error in the options' measure
  bool reached = false;      // false when even max_count missed the target
  int evaluations = 0;       // samplings + error evaluations made
  std::vector<Light> lights; // the lights at `count`
};

// `sampler` must already be prepared on the map that `reference` was built from.
AutoCountResult choose_light_count(Sampler& sampler, const AccuracyReference& reference,
                                   const AutoCountOptions& options);

// Per-frame automatic counts for a sequence, with hysteresis so that the count does not
// itself flicker: the count rises at once when the error exceeds the target (accuracy
// first), but falls only after the error has stayed below target * (1 - band) for
// hold_frames consecutive frames, and only to a count at least `band` smaller.
struct AutoCountHysteresis {
  double band = 0.25;   // relative margin below the target before a decrease is considered
  int hold_frames = 8;  // frames the margin must hold (about 0.4 s at 21 Hz)
};

class AutoCountTracker {
 public:
  AutoCountTracker(const AutoCountOptions& options, const AutoCountHysteresis& hysteresis = {});
  // `sampler` prepared on this frame's map, `reference` built from it.
  AutoCountResult update(Sampler& sampler, const AccuracyReference& reference);
  int count() const { return count_; }
  // A ceiling below options.max_count from now on (a frame budget, sampling/frame_budget.h):
  // the search stops there and reports the target as not reached, so a capped frame costs
  // no more than the cap. The count held is lowered to it at once.
  void limit(int max_count);

 private:
  AutoCountOptions options_;
  int ceiling_ = 0;       // options.max_count as given: limit() never goes above it
  AutoCountHysteresis hysteresis_;
  int count_ = 0;         // the count asked of the sampler (0: no frame yet)
  int below_streak_ = 0;  // consecutive frames comfortably below the target
};

}  // namespace lp
