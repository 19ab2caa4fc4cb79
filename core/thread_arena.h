#pragma once
// Work on a fixed number of threads, in a TBB arena made once per process and kept.
//
// Why: `tbb::task_arena arena(n); arena.execute(f)` in a per-frame function (the merge, the
// unwrap) builds and initialises a new arena on every call and lets its worker slots go
// when it is destroyed, so each frame pays the arena's set-up and the workers' wake-up
// anew. Reusing one arena per thread count keeps both out of the frame.
#include <functional>

namespace lp {

// Runs `work` inside the process's arena of `threads` concurrency (made on first use, then
// reused by every caller asking for the same count; safe to call from several threads at
// once). threads <= 0: runs `work` directly, in the caller's own arena (TBB's default).
void run_in_thread_arena(int threads, const std::function<void()>& work);

}  // namespace lp
