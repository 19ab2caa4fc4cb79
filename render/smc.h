// Sequential Monte Carlo across frames for one shading point (Ghosh et al. 2006, as
// Kronander et al. 2015, seed 002, section 6 describe it): N weighted particles follow the
// product target gamma_t = L_Y,t (f cos)_Y from frame to frame instead of being drawn anew.
//
// Per frame t (frame 0, and every reset, initialises by BIS: M = N x proposals_per_particle,
// proposals from the lobe as in the paper, or partly from the map: init_proposal_map_share):
//   1. propagate: w_i = W_i gamma_t(w_i) / gamma_{t-1}(w_i), Z_t = Z_{t-1} sum w_i (eq. 5, 8);
//      with K intermediate distributions gamma_{t-1}^(1-b) gamma_t^b, b = 1/(K+1) ... 1, the
//      reweighting runs in K + 1 steps, each followed by its MH moves (Ghosh et al.);
//   2. resample (systematic) when the effective sample size 1 / sum W_i^2 < ess_fraction N (2/3);
//   3. adapt: mh_moves Metropolis-Hastings moves per particle, invariant for the target:
//      with probability local_move_probability a uniform perturbation in a cap of
//      local_move_deg (symmetric), otherwise an independent draw from the map (share
//      independent_map_share) or the lobe, accepted with min(1, g(w') q(w) / g(w) q(w'));
//   4. estimate: Z_t sum W_i (L f cos V)(w_i) / gamma_t(w_i) (eq. 7).
// Reset (the paper's remedy for a drifting Z): re-initialise by BIS when Z_t / Z_{t-1} leaves
// [1 / reset_ratio, reset_ratio], when every weight is zero, or when the map's luminance power
// changes by more than map_power_reset_ratio. The last is ours: a light switched on where no
// particle sits changes Z_t without changing any weight, so only the map can reveal it.
// A light that moves is worse: each frame part of it lies where no particle was, the
// reweighting underestimates Z_t / Z_{t-1} a little, and Z drifts down frame after frame
// without ever tripping the ratio test; reset_every bounds that drift.
// SMC is consistent, not unbiased: its Z carries the error of every frame since the last reset.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "render/env_distribution.h"
#include "render/estimators.h"
#include "render/rng.h"

namespace lp {

struct SmcOptions {
  int particles = 8;                  // N (each costs a visibility test per frame)
  int proposals_per_particle = 8;     // BIS initialisation: M = 8 N
  double init_proposal_map_share = 0; // BIS initialisation's proposals from the map (0: lobe, as BIS)
  double ess_fraction = 2.0 / 3.0;    // resample when ESS < ess_fraction N (the paper's 2N/3)
  int mh_moves = 1;                   // per particle, per (intermediate) distribution
  double local_move_probability = 0.5;  // nu of the proposal mixture
  double local_move_deg = 3.0;        // half-angle of the uniform local perturbation
  double independent_map_share = 0.5; // independent moves: from the map with this share, else the lobe
  int intermediate = 0;               // K intermediate distributions between frames
  double reset_ratio = 2.0;           // reset when Z_t / Z_{t-1} leaves [1/r, r]; <= 1: never
  double map_power_reset_ratio = 1.1; // reset when map power changes by more than this; <= 1: never
  int reset_every = 0;                // also reset after this many frames without one; 0: never
};
// Throws InputError on particles < 1, proposals < 1, ess_fraction outside [0, 1], negative
// moves or intermediates, a probability outside [0, 1], or a non-positive cap angle.
void validate(const SmcOptions& options);

struct SmcStats {
  int frames = 0;
  int resamples = 0;     // ESS-triggered resampling steps
  int resets = 0;        // re-initialisations after frame 0
  long proposed = 0, accepted = 0;  // MH moves
  double last_ess = 0;   // after propagation, before resampling, at the last frame
  bool last_reset = false;
  bool last_resampled = false;
};

class SmcEstimator {
 public:
  // Validates the point and the options (InputError).
  SmcEstimator(ShadingPoint point, const SmcOptions& options, uint64_t seed);
  // Advance to the next frame's map; returns the reflected radiance estimate.
  Rgb step(std::shared_ptr<const EnvDistribution> frame);
  const SmcStats& stats() const { return stats_; }
  double normalising_constant() const { return z_; }
  int particle_count() const { return int(dir_.size()); }

 private:
  void initialise(const EnvDistribution& map);
  void reweight(double beta_to, const EnvDistribution& prev, const EnvDistribution& cur);
  void maybe_resample();
  void move(double beta, const EnvDistribution& prev, const EnvDistribution& cur);
  double bridge(double beta, const EnvDistribution& prev, const EnvDistribution& cur, Vec3 w) const;

  ShadingPoint point_;
  SmcOptions options_;
  Rng rng_;
  std::shared_ptr<const EnvDistribution> previous_;
  std::vector<Vec3> dir_;
  std::vector<double> weight_;  // normalised W_i
  std::vector<double> gamma_;   // the current bridge target at each particle
  double z_ = 0;
  double ratio_sum_ = 0;        // sum of unnormalised weights of the last reweighting
  int frames_since_reset_ = 0;
  SmcStats stats_;
};

}  // namespace lp
