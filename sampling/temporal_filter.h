// Temporal filtering of light lists (Havran et al. 2005, section 3.3): a causal,
// linear-phase FIR low-pass over (a) the total power per channel and (b) each light's
// direction, tracked by its stable id. The output lags the input by delay_frames().
#pragma once

#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "core/light_list.h"
#include "core/vec3.h"

namespace lp {

struct FirFilter {
  // y_t = sum_k taps[k] * x_{t-k}; symmetric (linear phase), odd count, sum exactly 1
  // (up to rounding) so that a constant signal, and so total power, passes unchanged.
  std::vector<double> taps;
  double sample_rate_hz = 0;
  // Group delay of a linear-phase FIR: (taps - 1) / 2 frames.
  int delay_frames() const { return taps.empty() ? 0 : (static_cast<int>(taps.size()) - 1) / 2; }
};

// Havran 2005's equiripple filter of order 8 for 21 Hz frames (pass 7 Hz, stop 9 Hz):
// w1=w9=0.06216, w2=w8=0.01296, w3=w7=-0.13816, w4=w6=0.28315, w5=0.65223.
// The printed coefficients sum to 1.09245, not 1 (a DC gain of +0.77 dB); they are
// returned divided by that sum so that power is preserved, as the paper intends
// ("the overall energy ... is preserved ... through normalizing the coefficients").
// Measured: these taps do not meet the stated 7/9 Hz spec; |H| falls to 0.43 at 7 Hz and
// the stop band is only about -21.5 dB. A design that meets it (design_lowpass_filter(21,
// 7, 9)) needs 25 taps, i.e. 12 frames of delay instead of 4; filter_for_frame_rate keeps
// the paper's short filter at 21 Hz.
FirFilter havran2005_filter();

// A low-pass for another frame rate: Kaiser-windowed sinc with cutoff (pass + stop) / 2,
// designed for 40 dB stop-band attenuation (Kaiser: beta = 0.5842 (A-21)^0.4 +
// 0.07886, order N = (A - 7.95) / (2.285 * 2 pi (stop - pass) / fs), rounded up
// to even so the tap count N + 1 is odd). Kaiser's order estimate is approximate, so the
// order is then raised by 2 until the measured response has >= 40 dB attenuation above
// stop_hz; taps are normalised to sum 1 (unit DC gain). Throws InputError unless
// 0 < pass_hz < stop_hz < sample_rate_hz / 2.
FirFilter design_lowpass_filter(double sample_rate_hz, double pass_hz, double stop_hz);

// Havran's taps for 21 Hz (+-0.5 Hz); otherwise design_lowpass_filter(fps, fps/3, 3 fps/7),
// the same ratios as 7/21 and 9/21. Throws InputError unless fps is positive and finite.
FirFilter filter_for_frame_rate(double fps);

// The filter applied to a scalar sequence by the same code path LightTemporalFilter uses,
// including its start rule (history filled with the first value): out[t] = sum_k
// taps[k] * in[max(t-k, 0)].
std::vector<double> apply_fir(const FirFilter& filter, const std::vector<double>& signal);

struct TemporalFilterOptions {
  bool filter_power = true;       // total power per channel
  bool filter_directions = true;  // each light's direction, by id
};

class LightTemporalFilter {
 public:
  // Throws InputError on an empty filter or taps that do not sum to a positive value.
  explicit LightTemporalFilter(FirFilter filter, TemporalFilterOptions options = {});

  // The filtered list for this frame (frame metadata copied from `frame`).
  //  - power: P~ = sum_k w_k P_{t-k} per channel, clamped at 0 (the FIR's negative lobes
  //    can undershoot after a drop to darkness); the lights are scaled per channel so that
  //    their sum is P~, each keeping its share of the current frame. A channel with zero
  //    current power gets P~ split equally over the lights.
  //  - directions: d~ = normalize(sum_k w_k d_{t-k}) over the light's id history; when that
  //    sum is (near) zero the current direction is kept.
  //  History: the first frame, and the first frame an id appears in, fill the history with
  //  that value, so a constant input passes unchanged from the first frame; an id missing
  //  from a frame is forgotten. Throws InputError when an id appears twice in one frame.
  LightList push(const LightList& frame);

  void reset();
  const FirFilter& filter() const { return filter_; }

 private:
  int slot_for(uint64_t id, bool& fresh);
  void free_slot(int slot);

  FirFilter filter_;
  TemporalFilterOptions options_;
  int n_taps_ = 0;
  int64_t frames_ = 0;  // frames pushed since construction or reset
  int head_ = 0;        // ring position of the newest sample, shared by every history

  std::vector<std::array<double, 3>> power_history_;  // n_taps ring of channel totals

  // Direction histories: slot s holds n_taps ring entries at [s * n_taps, (s+1) * n_taps).
  std::vector<Vec3> dir_history_;
  std::vector<uint64_t> slot_id_;
  std::vector<int64_t> slot_seen_;  // frame number the slot was last pushed in; -1 = free
  std::vector<int> free_slots_;
  std::vector<int> live_slots_;
  // id -> slot: a flat table for small ids (Halton indices), a hash map beyond.
  static constexpr uint64_t kSmallIds = 1 << 16;
  std::vector<int> small_slot_;
  std::unordered_map<uint64_t, int> large_slot_;
};

}  // namespace lp
