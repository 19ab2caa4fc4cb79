#include "sampling/auto_count.h"

#include <fmt/format.h>

#include <algorithm>
#include <utility>

#include "core/error.h"

namespace lp {

namespace {
constexpr std::pair<ErrorMeasure, std::string_view> kMeasureNames[] = {{ErrorMeasure::Diffuse, "diffuse"},
                                                                      {ErrorMeasure::Glossy10, "glossy10"},
                                                                      {ErrorMeasure::Glossy100, "glossy100"},
                                                                      {ErrorMeasure::Shadowed, "shadowed"},
                                                                      {ErrorMeasure::Worst, "worst"}};

double glossy_error(const LightError& error, const AccuracyOptions& reference, double exponent) {
  for (size_t i = 0; i < reference.glossy_exponents.size() && i < error.glossy.size(); ++i)
    if (reference.glossy_exponents[i] == exponent) return error.glossy[i];
  throw InputError(fmt::format("the accuracy reference has no glossy lobe s = {}", exponent));
}
}  // namespace

std::string_view to_string(ErrorMeasure measure) {
  for (const auto& [m, name] : kMeasureNames)
    if (m == measure) return name;
  return "?";
}

ErrorMeasure error_measure_from_string(std::string_view name) {
  for (const auto& [m, n] : kMeasureNames)
    if (n == name) return m;
  throw InputError(
      fmt::format("--error-measure: unknown measure '{}' (diffuse, glossy10, glossy100, shadowed, worst)", name));
}

AccuracyOptions reference_options_for(ErrorMeasure measure) {
  AccuracyOptions o;  // defaults: s = 10 and 100, shadowed on
  if (measure != ErrorMeasure::Worst && measure != ErrorMeasure::Shadowed) o.shadowed = false;
  if (measure == ErrorMeasure::Diffuse || measure == ErrorMeasure::Shadowed) o.glossy_exponents.clear();
  if (measure == ErrorMeasure::Glossy10) o.glossy_exponents = {10.0};
  if (measure == ErrorMeasure::Glossy100) o.glossy_exponents = {100.0};
  return o;
}

double measured_error(const LightError& error, const AccuracyOptions& reference, ErrorMeasure measure) {
  switch (measure) {
    case ErrorMeasure::Diffuse: return error.diffuse;
    case ErrorMeasure::Glossy10: return glossy_error(error, reference, 10.0);
    case ErrorMeasure::Glossy100: return glossy_error(error, reference, 100.0);
    case ErrorMeasure::Shadowed:
      if (!reference.shadowed) throw InputError("the accuracy reference was built without the shadowed measure");
      return error.shadowed;
    case ErrorMeasure::Worst:
      break;
  }
  double worst = error.diffuse;
  for (double g : error.glossy) worst = std::max(worst, g);
  return reference.shadowed ? std::max(worst, error.shadowed) : worst;
}

AutoCountResult choose_light_count(Sampler& sampler, const AccuracyReference& reference,
                                   const AutoCountOptions& options) {
  if (!(options.target_error > 0))
    throw InputError(fmt::format("--target-error must be positive, got {}", options.target_error));
  AutoCountResult result;
  auto evaluate = [&](int n) {
    auto lights = sampler.place(n);
    ++result.evaluations;
    const double e = measured_error(light_error(reference, lights), reference.options, options.measure);
    return std::make_pair(e, std::move(lights));
  };

  // Doubling phase: find the first power-of-two multiple that meets the target.
  int low = 0;  // largest count known to miss (0: none tried)
  int n = std::max(1, options.min_count);
  auto [err, lights] = evaluate(n);
  while (err > options.target_error && n < options.max_count) {
    low = n;
    n = std::min(options.max_count, 2 * n);
    std::tie(err, lights) = evaluate(n);
  }
  if (err > options.target_error) {
    result.count = int(lights.size());
    result.requested = n;
    result.error = err;
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
    if (e <= options.target_error) {
      high = mid;
      high_err = e;
      high_lights = std::move(l);
    } else {
      low = mid;
    }
  }
  result.count = int(high_lights.size());
  result.requested = high;
  result.error = high_err;
  result.lights = std::move(high_lights);
  result.reached = true;
  return result;
}

AutoCountTracker::AutoCountTracker(const AutoCountOptions& options, const AutoCountHysteresis& hysteresis)
    : options_(options), ceiling_(options.max_count), hysteresis_(hysteresis) {}

void AutoCountTracker::limit(int max_count) {
  options_.max_count = std::max(options_.min_count, std::min(ceiling_, max_count));
  count_ = std::min(count_, options_.max_count);
}

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
  held.error = measured_error(light_error(reference, held.lights), reference.options, options_.measure);
  held.count = int(held.lights.size());
  held.requested = count_;
  held.reached = held.error <= options_.target_error;
  if (!held.reached) {
    // Too few lights for this frame: rise at once, searching upwards from the current count.
    below_streak_ = 0;
    AutoCountResult r = search(count_);
    r.evaluations += held.evaluations;
    count_ = r.requested;
    return r;
  }
  if (held.error < options_.target_error * (1 - hysteresis_.band)) {
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
