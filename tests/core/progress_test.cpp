#include "core/progress.h"

#include <gtest/gtest.h>

#include <thread>
#include <vector>

namespace lp {
namespace {

TEST(Progress, DisabledBarPrintsNothingEvenFromManyThreads) {
  testing::internal::CaptureStderr();
  {
    Progress bar("frames", 4000, false);
    std::vector<std::thread> threads;
    for (int t = 0; t < 4; ++t)
      threads.emplace_back([&] {
        for (int i = 0; i < 1000; ++i) bar.advance();
      });
    for (auto& th : threads) th.join();
    bar.finish();
  }
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

TEST(Progress, BarIsSilentWhenStderrIsNotATerminal) {
  // CaptureStderr redirects fd 2 to a file, which is not a terminal.
  testing::internal::CaptureStderr();
  {
    Progress bar("maps", 10);
    for (int i = 0; i < 10; ++i) bar.advance();
  }  // the destructor finishes
  EXPECT_EQ(testing::internal::GetCapturedStderr(), "");
}

}  // namespace
}  // namespace lp
