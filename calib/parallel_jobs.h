// Independent jobs of a calibration stage (candidate solves, refits of splits and
// leave-one-out views) run on every core.
#pragma once

#include <cstddef>
#include <functional>

namespace lp {

// Runs job(0) ... job(n - 1), each once, on up to `threads` threads (0: as many as TBB's
// arena has cores), and returns when all are done; the first exception a job throws is
// rethrown here (the remaining jobs still run). Jobs start in index order, so a job that
// waits for another's result (CandidateSolver: the stereographic seed needs the
// Kannala-Brandt fit) should come after it. Each job runs isolated: while it waits inside a
// nested parallel region (OpenCV's, TBB's) its thread takes no other job of this call, so a
// job never ends up waiting beneath itself. Jobs must write only their own results; the
// results are then the same as a serial loop's whatever the timing.
void run_jobs(size_t n, const std::function<void(size_t)>& job, int threads = 0);

}  // namespace lp
