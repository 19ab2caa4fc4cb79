// The temporal measures of CONVENTIONS.md ("How accuracy is measured", Temporal), over a
// sequence of frames, each a reference map (or its reference irradiance) and the light
// list a method produced for it. Irradiance is diffuse, on luminance, over the N normals
// n_k of the spherical Fibonacci lattice (core/accuracy.h, N = 256):
//   E_ref(t, k)    the map integrated pixel by pixel (make_accuracy_reference's diffuse)
//   E_lights(t, k) sum_i Y_i max(0, n_k . d_i)
//   flicker        mean over frames t >= 1 and normals k of |dE_lights - dE_ref| / Ebar,
//                  dE(t, k) = E(t, k) - E(t-1, k), Ebar = mean of E_ref over all frames and
//                  normals. 0 when the lights follow every change of the reference exactly;
//                  lights that alternate +-a around an unchanging reference give 2a.
//   jitter_deg     mean angle (deg) between a light's directions in consecutive frames,
//                  pooled over every (t >= 1, id) with the id present in frames t-1 and t.
//                  Meant for a static scene with sensor noise (static-noise), where the
//                  ideal is 0. NaN when no id is ever present in two consecutive frames.
//   lag_frames     for a step at frame s (abrupt-switch): with the reference level
//                  R(t) = mean_k E_ref(t, k), pre = mean of R over frames [0, s),
//                  post = mean of R over [s, frames), the first t >= s at which
//                  mean_k E_lights(t, k) has gone 90 % of the way from pre to post (>= for a
//                  step up, <= for a step down), minus s. Integer-valued; +inf when never
//                  reached; NaN with no step frame given or when pre == post.
//   mean_diffuse_error  mean over frames of the diffuse rel_rms of core/accuracy.h.
// flicker is NaN with fewer than two frames. The scorer keeps 2 N doubles per frame.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <utility>
#include <vector>

#include "core/accuracy.h"
#include "core/envmap.h"
#include "core/light_list.h"
#include "core/vec3.h"

namespace lp {

struct TemporalReport {
  double flicker = 0;
  double jitter_deg = 0;
  double lag_frames = 0;  // NaN when no step
  double mean_diffuse_error = 0;
  int frames = 0;
};

class TemporalScorer {
 public:
  explicit TemporalScorer(int directions = 256);

  // Integrates the reference map (diffuse only; ~6 ms per latlong 1024x512 frame on 2 cores).
  void add_frame(const EnvMap& reference_map, std::span<const Light> lights);
  // Reuses a computed reference: E_ref per normal of normals(), in that order (InputError
  // when the count differs). A reference from make_accuracy_reference with the same
  // number of directions fits (its .diffuse).
  void add_frame(const std::vector<double>& reference_irradiance, std::span<const Light> lights);

  // InputError when step_frame is given but outside 1 .. frames-1.
  TemporalReport report(std::optional<int> step_frame = std::nullopt) const;

  const std::vector<Vec3>& normals() const { return normals_; }
  int frames() const { return int(reference_.size()); }
  // Per-frame values, for charts: E per normal of frame t.
  const std::vector<double>& reference_irradiance(int t) const { return reference_[size_t(t)]; }
  const std::vector<double>& lights_irradiance(int t) const { return lights_[size_t(t)]; }

 private:
  std::vector<Vec3> normals_;
  std::vector<std::vector<double>> reference_, lights_;
  std::vector<double> diffuse_error_;
  std::vector<std::pair<uint64_t, Vec3>> previous_;  // (id, direction) of the last frame, sorted by id
  double jitter_sum_rad_ = 0;
  size_t jitter_count_ = 0;
};

}  // namespace lp
