#include "calib/mrcal_solve.h"

#include <cmath>
#include <cstdio>
#include <fcntl.h>
#include <mutex>
#include <unistd.h>

extern "C" {
#include <mrcal/mrcal.h>
}

namespace lp {
namespace {

// mrcal's solver (libdogleg/CHOLMOD) writes warnings to stderr; the library prints nothing,
// so stderr points at /dev/null while any solve runs. Process-wide, and solves run on
// several threads at once (the selection's candidates): the first solve to start redirects,
// the last to end restores (a save/restore per solve would let two overlapping solves leave
// stderr at /dev/null for good).
class QuietStderr {
 public:
  QuietStderr() {
    std::lock_guard lock(mutex());
    if (state().depth++ > 0) return;
    std::fflush(stderr);
    state().saved = dup(2);
    const int devnull = open("/dev/null", O_WRONLY);
    if (state().saved >= 0 && devnull >= 0) dup2(devnull, 2);
    if (devnull >= 0) close(devnull);
  }
  ~QuietStderr() {
    std::lock_guard lock(mutex());
    if (--state().depth > 0) return;
    std::fflush(stderr);
    if (state().saved >= 0) {
      dup2(state().saved, 2);
      close(state().saved);
    }
    state().saved = -1;
  }
  QuietStderr(const QuietStderr&) = delete;
  QuietStderr& operator=(const QuietStderr&) = delete;

 private:
  struct State {
    int depth = 0, saved = -1;
  };
  static std::mutex& mutex() {
    static std::mutex m;
    return m;
  }
  static State& state() {
    static State s;
    return s;
  }
};

}  // namespace

int mrcal_model_param_count(const std::string& lensmodel) {
  mrcal_lensmodel_t m;
  if (!mrcal_lensmodel_from_name(&m, lensmodel.c_str()) || !mrcal_lensmodel_type_is_valid(m.type)) return -1;
  return mrcal_lensmodel_num_params(&m);
}

MrcalSolution mrcal_solve(const MrcalProblem& p) {
  MrcalSolution out;
  mrcal_lensmodel_t lensmodel;
  if (!mrcal_lensmodel_from_name(&lensmodel, p.lensmodel.c_str()) || !mrcal_lensmodel_type_is_valid(lensmodel.type)) {
    out.error = "mrcal does not know lens model " + p.lensmodel;
    return out;
  }
  const int nparams = mrcal_lensmodel_num_params(&lensmodel);
  const int nframes = static_cast<int>(p.poses_seed.size());
  const int ncorners = p.cols * p.rows;
  if (static_cast<int>(p.intrinsics_seed.size()) != nparams || nframes == 0 ||
      static_cast<int>(p.observations.size()) != nframes) {
    out.error = "mrcal problem: inconsistent sizes";
    return out;
  }
  std::vector<double> intrinsics = p.intrinsics_seed;
  std::vector<mrcal_pose_t> frames(nframes);
  for (int i = 0; i < nframes; ++i) {
    const auto& s = p.poses_seed[i];
    frames[i].r = {{s[0], s[1], s[2]}};
    frames[i].t = {{s[3], s[4], s[5]}};
  }
  std::vector<mrcal_observation_board_t> obs(nframes);
  std::vector<mrcal_point3_t> pool(static_cast<size_t>(nframes) * ncorners);
  for (int i = 0; i < nframes; ++i) {
    obs[i].icam.intrinsics = 0;
    obs[i].icam.extrinsics = -1;  // the camera is the reference frame
    obs[i].iframe = i;
    if (static_cast<int>(p.observations[i].size()) != ncorners) {
      out.error = "mrcal problem: a view without cols*rows corners";
      return out;
    }
    for (int k = 0; k < ncorners; ++k) {
      const auto& o = p.observations[i][k];
      pool[static_cast<size_t>(i) * ncorners + k] = {{o[0], o[1], o[2]}};
    }
  }
  mrcal_problem_selections_t sel{};
  sel.do_optimize_intrinsics_core = p.optimize_intrinsics;
  sel.do_optimize_intrinsics_distortions = p.optimize_intrinsics;
  sel.do_optimize_extrinsics = false;
  sel.do_optimize_frames = true;
  sel.do_optimize_calobject_warp = p.optimize_warp;
  mrcal_calobject_warp_t warp{};
  warp.x2 = p.warp_seed[0];
  warp.y2 = p.warp_seed[1];
  sel.do_apply_regularization = p.regularization;
  sel.do_apply_outlier_rejection = false;
  mrcal_problem_constants_t constants{};
  constants.point_min_range = -1;
  constants.point_max_range = -1;
  const int imagersizes[2] = {p.width, p.height};

  mrcal_stats_t stats;
  {
    const QuietStderr quiet;
    stats = mrcal_optimize(nullptr, 0, nullptr, 0, intrinsics.data(), nullptr, frames.data(), nullptr,
                           p.optimize_warp ? &warp : nullptr, 1, 0, nframes, 0, 0, obs.data(), nullptr, nframes, 0,
                           pool.data(), &lensmodel, imagersizes, sel, &constants, p.spacing, p.cols, p.rows, false,
                           false);
  }
  if (!(stats.rms_reproj_error__pixels >= 0) || !std::isfinite(stats.rms_reproj_error__pixels)) {
    out.error = "mrcal_optimize failed for " + p.lensmodel;
    return out;
  }
  for (double v : intrinsics)
    if (!std::isfinite(v) || !std::isfinite(warp.x2) || !std::isfinite(warp.y2)) {
      out.error = "mrcal_optimize diverged for " + p.lensmodel;
      return out;
    }
  out.ok = true;
  out.intrinsics = intrinsics;
  out.rms_px = stats.rms_reproj_error__pixels;
  if (p.optimize_warp) out.warp = {warp.x2, warp.y2};
  out.poses.resize(nframes);
  for (int i = 0; i < nframes; ++i)
    out.poses[i] = {frames[i].r.x, frames[i].r.y, frames[i].r.z, frames[i].t.x, frames[i].t.y, frames[i].t.z};
  return out;
}

}  // namespace lp
