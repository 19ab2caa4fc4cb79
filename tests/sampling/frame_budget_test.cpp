// sampling/frame_budget.h, driven with given frame times: the cap falls at once to what
// fits, rises only after a run of frames well under budget, and holds through noise
// between the two, so that the light count cannot flicker with the machine's load.
#include <gtest/gtest.h>

#include <limits>
#include <vector>

#include "core/error.h"
#include "sampling/frame_budget.h"

namespace lp {
namespace {

FrameBudgetOptions budget(double ms) {
  FrameBudgetOptions o;
  o.budget_ms = ms;
  return o;
}

TEST(FrameBudget, OverBudgetTheCapFallsAtOnceToWhatFits) {
  FrameBudget b(budget(10));
  EXPECT_EQ(b.cap(), 16384);
  EXPECT_EQ(b.update(400, 20), 190);  // 400 * 10/20 * 0.95
  EXPECT_EQ(b.update(190, 9.5), 190);  // fits: held
  EXPECT_EQ(b.update(190, 1000), 16);  // never below min_count
}

TEST(FrameBudget, UnderBudgetTheCapRisesOnlyAfterTheHoldTime) {
  FrameBudgetOptions o = budget(10);
  o.hold_frames = 4;
  FrameBudget b(o);
  b.update(200, 20);  // cap 95
  std::vector<int> caps;
  for (int i = 0; i < 8; ++i) caps.push_back(b.update(95, 5));
  EXPECT_EQ(caps, (std::vector<int>{95, 95, 95, 104, 104, 104, 104, 114}));
  // a frame in the band between 0.7 B and B restarts the run
  for (int i = 0; i < 3; ++i) b.update(114, 5);
  b.update(114, 8);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(b.update(114, 5), 114);
}

TEST(FrameBudget, NoiseInsideTheBandNeverMovesTheCap) {
  FrameBudget b(budget(10));
  b.update(300, 15);  // cap 190
  for (int i = 0; i < 100; ++i) EXPECT_EQ(b.update(190, i % 2 ? 7.2 : 9.9), 190) << i;
}

TEST(FrameBudget, ABudgetThatIsNoNumberOfMillisecondsIsRefused) {
  for (double ms : {0.0, -1.0, std::numeric_limits<double>::infinity()}) EXPECT_THROW(FrameBudget{budget(ms)}, InputError) << ms;
}

}  // namespace
}  // namespace lp
