// n lights for the strongest, most directional part of a map plus SH9 for what they leave
// out (`sample --residual sh9`), so that a renderer shadows the n lights and adds the rest
// as unshadowed ambient.
//
// The split, per valid pixel of luminance Y and a threshold tau on luminance:
//   peaks     P = L max(0, 1 - tau / Y)   (the part above tau, the pixel's colour kept)
//   residual  R = L - P = L min(1, tau / Y)   (the map clamped at luminance tau)
// The lights sample P (every method keeps P's power, sampler.h), the SH9 projects R
// (sqrt(4 pi) L00 is R's integral), so sum rgb_i + SH power = the map's integral.
// tau is the luminance above which the brightest pixels cover n times the solid angle of
// a cap of `light_cap_deg`: what n directional lights can stand for without smearing.
// A map without such peaks (nothing above tau) gets no lights, all ambient.
#pragma once

#include "core/accuracy.h"
#include "core/envmap.h"
#include "core/light_list.h"
#include "sampling/sampler.h"

namespace lp {

struct LightsAndAmbientOptions {
  // Half-angle of the cap one light stands for. Larger: the lights take more of the map
  // (better shadows, coarser lights); smaller: more goes to the unshadowed ambient.
  double light_cap_deg = 5.0;
};

struct PeakSplit {
  EnvMap peaks, residual;
  double threshold = 0;   // tau (luminance)
};
PeakSplit split_peaks(const EnvMap& map, int n, const LightsAndAmbientOptions& options = {});

struct LightsAndAmbient {
  LightList list;                 // n lights (or none) + sh9 with content "residual"
  double threshold = 0;           // tau
  double light_power_share = 0;   // luminance power in the lights / the map's
};
// Throws InputError as the sampler and project_sh9 do (bad pixels, no valid pixels, n <= 0).
LightsAndAmbient sample_lights_and_sh9(const EnvMap& map, int n, Method method, const SamplerOptions& sampler = {},
                                       const LightsAndAmbientOptions& options = {});

// The yardstick of CONVENTIONS.md for the three ways to light with n: n lights + SH9 of
// the residual, n lights of the whole map alone, SH9 of the whole map alone (ambient
// never shadowed: core/accuracy.h).
struct AmbientComparison {
  LightList list;  // the n lights + SH9 scored first
  LightError lights_and_sh9, lights_only, sh9_only;
  double light_power_share = 0;
};
AmbientComparison compare_lights_and_sh9(const EnvMap& map, const AccuracyReference& reference, int n, Method method,
                                         const SamplerOptions& sampler = {}, const LightsAndAmbientOptions& options = {});

}  // namespace lp
