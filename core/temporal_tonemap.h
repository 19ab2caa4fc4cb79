// Tone mapping of a live map over time (Havran et al. 2005 §5, seed 001): the global
// operator of Reinhard et al. 2002, exposure k = a / L_w (a pixel of luminance Y is shown
// as kY / (1 + kY), core/tonemap.h), with its two parameters, the world luminance L_w and
// the key a, low-pass filtered across frames instead of set anew for every frame. A lamp
// that switches on shows at once; the exposure follows over a time constant, so the rest
// of the picture does not pump and sensor noise does not flicker its brightness.
//
// Per frame (frame_tone_parameters), over the pixels seen (valid and finite):
//   L_w = exp(mean log(delta + Y)), delta = 1e-4 x the frame's largest Y (so that black
//         pixels count as 80 dB down, whatever the units);
//   a   = Reinhard's automatic key (Reinhard 2002, "Parameter estimation for photographic
//         tone reproduction"): 0.18 x 4^((2 log2 L_w - log2 L_lo - log2 L_hi) /
//         (log2 L_hi - log2 L_lo)), L_lo and L_hi the 1st and 99th percentiles of Y
//         (robust minimum and maximum); 0.18 for a map of one luminance. Fixed by `key`.
// Over time (TemporalToneMapper::update), a first-order filter on log L_w and log a with
// time constant tau:  x <- x + (1 - exp(-dt / tau)) (x_frame - x).
//   - after a step the gap left after t seconds is exp(-t / tau) of it (in log): under 1 %
//     after 4.61 tau (49 frames at 21 fps with tau = 0.5 s);
//   - per frame the exposure moves by at most the factor (k_frame / k)^(1 - exp(-dt/tau))
//     (at 21 fps, tau = 0.5 s: 9.1 % of the step in log, 1.23x of a 10x step);
//   - the first frame (and the first after reset()) sets the state directly.
// Time comes from the frames' timestamps, so the adaptation takes as long whether a
// preview is rendered for every frame or for a few.
#pragma once

#include "core/image_view.h"

namespace lp {

struct TemporalToneMapOptions {
  double time_constant_s = 0.5;   // tau of the filter on log L_w and log a
  double key = 0;                 // > 0: this key a instead of the automatic one
  double fallback_frame_s = 0.05; // dt used when timestamps give none (not finite or <= 0)
};

struct ToneMapParameters {
  double world_luminance = 0;  // L_w; 0: nothing seen yet
  double key = 0.18;           // a
  double exposure() const { return world_luminance > 0 ? key / world_luminance : 0; }
};

// One frame's own parameters (what a per-frame operator would use). world_luminance is 0
// when no pixel is seen or every seen pixel is black.
ToneMapParameters frame_tone_parameters(ImageView image, double fixed_key = 0);

class TemporalToneMapper {
 public:
  explicit TemporalToneMapper(TemporalToneMapOptions options = {});
  // Folds in the next frame, dt_s seconds after the previous one, and returns the filtered
  // parameters. A frame with nothing seen, or black, leaves them as they were.
  const ToneMapParameters& update(ImageView image, double dt_s);
  // The same with one frame's parameters already computed.
  const ToneMapParameters& update(const ToneMapParameters& frame, double dt_s);
  const ToneMapParameters& parameters() const { return state_; }
  void reset() { state_ = {}; }

 private:
  TemporalToneMapOptions options_;
  ToneMapParameters state_;
};

}  // namespace lp
