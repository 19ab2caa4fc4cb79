#pragma once
// Process-wide heap settings for programs that run the calibration solvers. Opt-in: a
// library must not change its host program's allocator, so calib/ never calls this; the
// `lightprobe` commands that calibrate do, and so do the calibration tests.

namespace lp {

// Keeps 64 MB at the heap's top and serves blocks up to 32 MB from the heap (glibc's
// M_TOP_PAD, M_MMAP_THRESHOLD). The solvers allocate and free dense matrices by the
// thousand (cv::omnidir::calibrate zeroes a fresh Jacobian and normal matrix every
// iteration; cv::calibrateCamera, Ceres, mrcal do alike): with glibc's defaults the heap's
// top goes back to the kernel after each and is faulted in again, zeroed, by the next. On
// this project's 2-core VMs page faults are dear: `calib geometric` on fisheye1 spent 6.5 s
// of 16.5 in the kernel, 58 % of its samples in memset's faults; with the top kept, 6 s,
// 0.15 s in the kernel, the same answer (docs/calibration.md, "Selection at the cost of one
// solve"). Idempotent, never undone; a no-op without glibc.
void keep_heap_top_for_solvers();

}  // namespace lp
