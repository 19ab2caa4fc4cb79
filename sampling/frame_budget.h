// A frame-time budget for the live back end (stream --n auto --frame-budget-ms B): Havran
// et al. 2005 adjust the number of lights so that the frame rate holds. Here the budget
// caps the count the error target asks for (sampling/auto_count.h), never raises it above
// that: the fewest lights that reach the target, unless the budget cannot afford them.
//
// A feedback rule on the measured back-end time of each frame (prepare + place + the auto
// count's reference and search + temporal), not a model of the cost per light: the cost
// is not linear in the count (the reference build is fixed, the search is ~log n) and
// the machine's load changes under it.
//   over budget:   cap = count * B / ms * 0.95 at once (the next frame fits if the time
//                  scales with the count), never below min_count;
//   under raise_below * B for hold_frames frames in a row: cap grows by raise_factor;
//   otherwise the cap holds, so that timing noise cannot make the count flicker.
// Pure: the caller measures the time and passes it in (tests drive it with given times).
#pragma once

namespace lp {

struct FrameBudgetOptions {
  double budget_ms = 0;       // 0: no budget
  double raise_below = 0.7;   // a frame this far under budget counts toward a raise
  int hold_frames = 8;        // consecutive such frames before the cap rises
  double raise_factor = 1.1;  // growth per raise (at least one light)
  int min_count = 16;         // the cap never goes below this (q2tree's 12 base quads)
  int max_count = 16384;
};

class FrameBudget {
 public:
  explicit FrameBudget(const FrameBudgetOptions& options);
  // A frame with `count` lights took `ms` in the back end; returns the cap for the next.
  int update(int count, double ms);
  int cap() const { return cap_; }
  const FrameBudgetOptions& options() const { return options_; }

 private:
  FrameBudgetOptions options_;
  int cap_;
  int under_streak_ = 0;
};

}  // namespace lp
