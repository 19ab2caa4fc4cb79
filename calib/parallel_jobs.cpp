#include "calib/parallel_jobs.h"

#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <exception>
#include <mutex>

namespace lp {

void run_jobs(size_t n, const std::function<void(size_t)>& job, int threads) {
  const size_t workers =
      std::min(n, size_t(threads > 0 ? threads : std::max(1, tbb::this_task_arena::max_concurrency())));
  if (workers <= 1) {
    for (size_t i = 0; i < n; ++i) job(i);
    return;
  }
  // A shared counter rather than tbb::parallel_for: the jobs start in index order (a range
  // split in halves would start the second half's first job, maybe one that waits, at once).
  std::atomic<size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  const auto worker = [&] {
    for (size_t i; (i = next.fetch_add(1)) < n;) {
      try {
        tbb::this_task_arena::isolate([&] { job(i); });
      } catch (...) {
        std::lock_guard lock(error_mutex);
        if (!error) error = std::current_exception();
      }
    }
  };
  tbb::task_group group;
  for (size_t w = 1; w < workers; ++w) group.run(worker);
  worker();
  group.wait();
  if (error) std::rethrow_exception(error);
}

}  // namespace lp
