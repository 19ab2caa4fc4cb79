// core/thread_arena.h: the work runs with the concurrency asked for, and callers on several
// threads at once, sharing the kept arenas, all get their work done, once each.
#include "core/thread_arena.h"

#include <gtest/gtest.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <thread>
#include <vector>

namespace lp {
namespace {

TEST(ThreadArena, RunsTheWorkWithTheConcurrencyAskedFor) {
  for (int threads : {1, 2, 3}) {
    int seen = 0;
    run_in_thread_arena(threads, [&] { seen = tbb::this_task_arena::max_concurrency(); });
    EXPECT_EQ(seen, threads);
  }
  // threads <= 0: the caller's own arena (TBB's default concurrency).
  int seen = 0;
  run_in_thread_arena(0, [&] { seen = tbb::this_task_arena::max_concurrency(); });
  EXPECT_EQ(seen, tbb::this_task_arena::max_concurrency());
}

TEST(ThreadArena, CallersOnSeveralThreadsShareTheArenas) {
  int other = -1;
  // Several callers of the same count at once: each one's work runs, and runs once, with the
  // arena's concurrency.
  std::atomic<int> done{0}, wrong{0};
  std::vector<std::thread> callers;
  for (int i = 0; i < 4; ++i)
    callers.emplace_back([&] {
      for (int k = 0; k < 50; ++k)
        run_in_thread_arena(2, [&] {
          done.fetch_add(1);
          if (tbb::this_task_arena::max_concurrency() != 2) wrong.fetch_add(1);
        });
    });
  for (std::thread& t : callers) t.join();
  EXPECT_EQ(done.load(), 200);
  EXPECT_EQ(wrong.load(), 0);
  run_in_thread_arena(3, [&] { other = tbb::this_task_arena::max_concurrency(); });
  EXPECT_EQ(other, 3);
}

}  // namespace
}  // namespace lp
