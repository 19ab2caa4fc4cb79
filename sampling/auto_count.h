// "Model no more than a scene needs": the smallest light count whose diffuse error
// (core/accuracy.h) is at most a target.
//
// Assumption: the diffuse error of a method falls (not necessarily strictly) as n
// grows. It is not exactly monotone for low-discrepancy points, so the search brackets:
// it doubles n until the target is met, then bisects between the last count that missed
// and the first that met it. Where the error is not monotone inside that bracket, the
// answer is a count that meets the target, possibly not the very smallest.
// Cost: about 2 log2(n) samplings and error evaluations instead of n.
#pragma once

#include "core/accuracy.h"
#include "sampling/sampler.h"

namespace lp {

struct AutoCountOptions {
  double target_diffuse_error = 0.01;  // relative RMS, e.g. 0.01 = 1 %
  int min_count = 16;  // q2tree cannot go below its 12 base quads
  int max_count = 16384;  // give up (and report it) above this
};

struct AutoCountResult {
  int count = 0;             // lights returned (q2tree may return up to 2 fewer than asked)
  int requested = 0;         // the n asked of the sampler for them
  double diffuse_error = 0;  // its error
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

 private:
  AutoCountOptions options_;
  AutoCountHysteresis hysteresis_;
  int count_ = 0;         // the count asked of the sampler (0: no frame yet)
  int below_streak_ = 0;  // consecutive frames comfortably below the target
};

}  // namespace lp
