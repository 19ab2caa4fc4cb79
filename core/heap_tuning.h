#pragma once
// Process-wide heap settings for programs that allocate and free the same large buffers over
// and over: the calibration solvers, and a probe sequence's frames. Opt-in: a library must
// not change its host program's allocator, so calib/ and probe/ never call this; the
// `lightprobe` commands that calibrate, unwrap a sequence, register photos or run `eval
// calib` / `eval unwrap` do, and so do the calibration and probe tests.

namespace lp {

// Serves blocks up to 32 MB from the heap (glibc's M_MMAP_THRESHOLD), keeps 64 MB at the
// heap's top (M_TOP_PAD), and gives the top back to the kernel only when 512 MB of it are
// free (M_TRIM_THRESHOLD). The solvers allocate and free dense matrices by the thousand
// (cv::omnidir::calibrate zeroes a fresh Jacobian and normal matrix every iteration;
// cv::calibrateCamera, Ceres, mrcal do alike): with glibc's defaults the heap's top goes back
// to the kernel after each and is faulted in again, zeroed, by the next. On this project's
// 2-core VMs page faults are dear: `calib geometric` on fisheye1 spent 6.5 s of 16.5 in the
// kernel, 58 % of its samples in memset's faults; with the top kept, 6 s, 0.15 s in the
// kernel, the same answer (docs/calibration.md, "Selection at the cost of one solve").
// find_ball frees ~250 MB of images a 1920 x 1080 frame (docs/probes.md, "Sequences"): with
// the top pad alone all but 64 MB of it went back after every frame, 44,000 faults a frame.
// Idempotent, never undone; a no-op without glibc.
void keep_heap_for_reuse();

}  // namespace lp
