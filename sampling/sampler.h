// Environment map -> directional lights. Every method behind one interface, split into
// pre-processing (prepare: CDFs, summed tables, per-frame work) and placement (place: the
// n lights), so that each can be timed on its own.
//
// Contract for every method:
//   - exactly n lights (q2tree: n - 2 to n, the Q2-tree splits four at a time, and at
//     least its 12 base quads: n < 12 throws InputError),
//   - sum of rgb equal to the map's total power over its valid region (1e-5 relative),
//   - ids stable from frame to frame (Halton index for pharr/hemigon, HEALPix NUNIQ node
//     for q2tree, split-path code for mediancut),
//   - pharr and hemigon are progressive: the first k lights of an n-light answer are a
//     good k-light answer (their power rescaled); not hemigon with lloyd_relaxed,
//     whose relaxed points depend on n (its ids are still the Halton indices).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/envmap.h"
#include "core/light_list.h"

namespace lp {

enum class Method { Pharr, Hemigon, Q2Tree, MedianCut };
std::string_view to_string(Method method);
std::optional<Method> method_from_string(std::string_view name);
std::vector<Method> all_methods();

struct SamplerOptions {
  // hemigon: sample only the upper hemisphere (sky-only probes, e.g. an upward fisheye).
  bool upper_only = false;
  // hemigon: Lloyd-relaxed Halton points (computed once per n, cached).
  bool lloyd_relaxed = false;
  // q2tree: importance p = L^a * dw^b.
  double q2_luminance_exponent = 1.0;   // a
  double q2_solid_angle_exponent = 0.25;  // b
  // q2tree: place each light at the deterministic jitter of the paper instead of the
  // luminance-weighted centroid of its leaf.
  bool q2_jitter = false;
  // q2tree: HEALPix resolution the map is binned to (power of two); 0 picks the nside
  // whose pixels are closest to the input's.
  int q2_nside = 0;
  // q2tree: keep the tree between frames. prepare() re-evaluates the previous frame's
  // nodes on the new map and restores the greedy order by merge-and-split pairs
  // (Nikodym et al. 3.2) instead of rebuilding; place(n) then gives exactly the lights a
  // fresh sampler would (same ids, directions, rgb). Falls back to a rebuild when the
  // map's geometry changes, and when exactness cannot be guaranteed (negative exponents
  // or negative pixels).
  bool q2_incremental = true;
};

class Sampler {
 public:
  virtual ~Sampler() = default;
  virtual Method method() const = 0;
  // Pre-processing of one frame. Throws InputError on maps it cannot sample (all zero,
  // NaN, wrong layout for the method). The map must stay alive and unchanged until the
  // frame's last place(): pharr, mediancut and hemigon read its colours there rather
  // than copy them (the copy was a third of their prepare).
  virtual void prepare(const EnvMap& map) = 0;
  // Places n > 0 lights on the prepared frame.
  virtual std::vector<Light> place(int n) = 0;
};

std::unique_ptr<Sampler> make_sampler(Method method, const SamplerOptions& options = {});

// prepare + place in one call, wrapped as a LightList (method and units filled in).
LightList sample(const EnvMap& map, int n, Method method, const SamplerOptions& options = {});

}  // namespace lp
