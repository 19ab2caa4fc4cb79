#include "sampling/auto_count.h"

#include <fmt/format.h>

#include "core/error.h"

namespace lp {

AutoCountResult choose_light_count(Sampler& sampler, const AccuracyReference& reference,
                                   const AutoCountOptions& options) {
  if (!(options.target_diffuse_error > 0))
    throw InputError(fmt::format("--target-error must be positive, got {}", options.target_diffuse_error));
  AutoCountResult result;
  auto evaluate = [&](int n) {
    auto lights = sampler.place(n);
    ++result.evaluations;
    const double e = light_error(reference, lights).diffuse;
    return std::make_pair(e, std::move(lights));
  };

  // Doubling phase: find the first power-of-two multiple that meets the target.
  int low = 0;  // largest count known to miss (0: none tried)
  int n = std::max(1, options.min_count);
  auto [err, lights] = evaluate(n);
  while (err > options.target_diffuse_error && n < options.max_count) {
    low = n;
    n = std::min(options.max_count, 2 * n);
    std::tie(err, lights) = evaluate(n);
  }
  if (err > options.target_diffuse_error) {
    result.count = int(lights.size());
    result.requested = n;
    result.diffuse_error = err;
    result.lights = std::move(lights);
    return result;
  }
  // Bisection between a miss (low) and a hit (n).
  int high = n;
  double high_err = err;
  std::vector<Light> high_lights = std::move(lights);
  while (high - low > 1 && low > 0) {
    const int mid = low + (high - low) / 2;
    auto [e, l] = evaluate(mid);
    if (e <= options.target_diffuse_error) {
      high = mid;
      high_err = e;
      high_lights = std::move(l);
    } else {
      low = mid;
    }
  }
  result.count = int(high_lights.size());
  result.requested = high;
  result.diffuse_error = high_err;
  result.lights = std::move(high_lights);
  result.reached = true;
  return result;
}

AutoCountTracker::AutoCountTracker(const AutoCountOptions& options, const AutoCountHysteresis& hysteresis)
    : options_(options), hysteresis_(hysteresis) {}

AutoCountResult AutoCountTracker::update(Sampler& sampler, const AccuracyReference& reference) {
  auto search = [&](int min_count) {
    AutoCountOptions o = options_;
    o.min_count = std::max(options_.min_count, min_count);
    AutoCountResult r = choose_light_count(sampler, reference, o);
    return r;
  };
  if (count_ == 0) {
    AutoCountResult r = search(options_.min_count);
    count_ = r.requested;
    return r;
  }
  AutoCountResult held;
  held.lights = sampler.place(count_);
  held.evaluations = 1;
  held.diffuse_error = light_error(reference, held.lights).diffuse;
  held.count = int(held.lights.size());
  held.requested = count_;
  held.reached = held.diffuse_error <= options_.target_diffuse_error;
  if (!held.reached) {
    // Too few lights for this frame: rise at once, searching upwards from the current count.
    below_streak_ = 0;
    AutoCountResult r = search(count_);
    r.evaluations += held.evaluations;
    count_ = r.requested;
    return r;
  }
  if (held.diffuse_error < options_.target_diffuse_error * (1 - hysteresis_.band)) {
    if (++below_streak_ >= hysteresis_.hold_frames) {
      below_streak_ = 0;
      AutoCountResult r = search(options_.min_count);
      r.evaluations += held.evaluations;
      if (r.reached && r.requested <= int(count_ * (1 - hysteresis_.band))) {
        count_ = r.requested;
        return r;
      }
      held.evaluations = r.evaluations;
    }
  } else {
    below_streak_ = 0;
  }
  return held;
}

}  // namespace lp
