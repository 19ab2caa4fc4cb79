#include "sampling/frame_budget.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace lp {

FrameBudget::FrameBudget(const FrameBudgetOptions& options) : options_(options), cap_(options.max_count) {
  if (!(options.budget_ms > 0) || !std::isfinite(options.budget_ms))
    throw InputError(fmt::format("--frame-budget-ms must be a positive number of milliseconds, got {}", options.budget_ms));
}

int FrameBudget::update(int count, double ms) {
  const double budget = options_.budget_ms;
  if (ms > budget) {
    under_streak_ = 0;
    const int fits = int(std::floor(double(count) * budget / ms * 0.95));
    cap_ = std::max(options_.min_count, std::min(cap_, fits));
  } else if (ms < options_.raise_below * budget) {
    if (++under_streak_ >= options_.hold_frames) {
      under_streak_ = 0;
      cap_ = std::min(options_.max_count, std::max(cap_ + 1, int(std::floor(cap_ * options_.raise_factor))));
    }
  } else {
    under_streak_ = 0;
  }
  return cap_;
}

}  // namespace lp
