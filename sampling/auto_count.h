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
  int count = 0;             // the chosen n (the best found when !reached)
  double diffuse_error = 0;  // its error
  bool reached = false;      // false when even max_count missed the target
  int evaluations = 0;       // samplings + error evaluations made
  std::vector<Light> lights; // the lights at `count`
};

// `sampler` must already be prepared on the map that `reference` was built from.
AutoCountResult choose_light_count(Sampler& sampler, const AccuracyReference& reference,
                                   const AutoCountOptions& options);

}  // namespace lp
