#include "sampling/temporal_filter.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdio>
#include <numeric>
#include <string>

#include "core/error.h"

namespace lp {
namespace {

// --- the one FIR step every signal goes through --------------------------------------
// ring holds n samples, the newest at `head`; x_{t-k} is ring[(head - k) mod n].
inline void add_scaled(double& acc, double w, double x) { acc += w * x; }
inline void add_scaled(Vec3& acc, double w, const Vec3& x) {
  acc.x += w * x.x;
  acc.y += w * x.y;
  acc.z += w * x.z;
}
inline void add_scaled(std::array<double, 3>& acc, double w, const std::array<double, 3>& x) {
  for (int c = 0; c < 3; ++c) acc[c] += w * x[c];
}

template <class T>
T fir_output(const double* taps, int n, const T* ring, int head) {
  T acc{};
  int k = 0;
  for (int i = head; i >= 0; --i, ++k) add_scaled(acc, taps[k], ring[i]);
  for (int i = n - 1; k < n; --i, ++k) add_scaled(acc, taps[k], ring[i]);
  return acc;
}

// Writes x as the newest sample; on the first sample of a history, fills all of it.
template <class T>
void ring_push(T* ring, int n, int head, const T& x, bool first) {
  if (first) {
    std::fill(ring, ring + n, x);
  } else {
    ring[head] = x;
  }
}

// --- design helpers ---------------------------------------------------------------------
double bessel_i0(double x) {
  // Power series sum ((x/2)^k / k!)^2; converges quickly for the betas used here.
  double sum = 1, term = 1;
  const double q = x * x / 4;
  for (int k = 1; k < 200; ++k) {
    term *= q / (static_cast<double>(k) * k);
    sum += term;
    if (term < sum * 1e-17) break;
  }
  return sum;
}

double magnitude_at(const std::vector<double>& taps, double f_over_fs) {
  std::complex<double> h = 0;
  for (size_t k = 0; k < taps.size(); ++k) h += taps[k] * std::polar(1.0, -2 * M_PI * f_over_fs * static_cast<double>(k));
  return std::abs(h);
}

std::vector<double> kaiser_sinc(int order, double cutoff_over_fs, double beta) {
  std::vector<double> taps(order + 1);
  const double m = order / 2.0;
  const double i0b = bessel_i0(beta);
  for (int k = 0; k <= order; ++k) {
    const double t = k - m;
    const double sinc = t == 0 ? 2 * cutoff_over_fs : std::sin(2 * M_PI * cutoff_over_fs * t) / (M_PI * t);
    const double r = t / m;
    const double window = bessel_i0(beta * std::sqrt(std::max(0.0, 1 - r * r))) / i0b;
    taps[k] = sinc * window;
  }
  const double sum = std::accumulate(taps.begin(), taps.end(), 0.0);
  for (double& w : taps) w /= sum;
  return taps;
}

std::string hz(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%g Hz", v);
  return buf;
}

}  // namespace

FirFilter havran2005_filter() {
  FirFilter f;
  f.taps = {0.06216, 0.01296, -0.13816, 0.28315, 0.65223, 0.28315, -0.13816, 0.01296, 0.06216};
  const double sum = std::accumulate(f.taps.begin(), f.taps.end(), 0.0);  // 1.09245
  for (double& w : f.taps) w /= sum;
  f.sample_rate_hz = 21;
  return f;
}

FirFilter design_lowpass_filter(double fs, double pass_hz, double stop_hz) {
  if (!(std::isfinite(fs) && std::isfinite(pass_hz) && std::isfinite(stop_hz)) || fs <= 0 || pass_hz <= 0 ||
      stop_hz <= 0)
    throw InputError("FIR design: sample rate " + hz(fs) + ", pass " + hz(pass_hz) + " and stop " + hz(stop_hz) +
                     " must be positive and finite");
  if (pass_hz >= stop_hz)
    throw InputError("FIR design: pass frequency " + hz(pass_hz) + " must be below the stop frequency " + hz(stop_hz));
  if (stop_hz >= fs / 2)
    throw InputError("FIR design: stop frequency " + hz(stop_hz) + " must be below half the sample rate (" +
                     hz(fs / 2) + ")");

  constexpr double kAttenuationDb = 40;
  const double beta = 0.5842 * std::pow(kAttenuationDb - 21, 0.4) + 0.07886 * (kAttenuationDb - 21);
  const double transition = 2 * M_PI * (stop_hz - pass_hz) / fs;  // radians per sample
  int order = static_cast<int>(std::ceil((kAttenuationDb - 7.95) / (2.285 * transition)));
  order = std::max(2, order + (order % 2));
  const double cutoff = 0.5 * (pass_hz + stop_hz) / fs;
  const double stop_gain = std::pow(10.0, -kAttenuationDb / 20);

  for (int attempt = 0;; ++attempt) {
    std::vector<double> taps = kaiser_sinc(order, cutoff, beta);
    // Measured worst stop-band gain on a fine grid from stop_hz to fs/2.
    double worst = 0;
    const int grid = 512;
    for (int i = 0; i <= grid; ++i) {
      const double f = stop_hz + (fs / 2 - stop_hz) * i / grid;
      worst = std::max(worst, magnitude_at(taps, f / fs));
    }
    if (worst <= stop_gain || attempt >= 64) {  // 64 steps of +2 only for pathological widths
      FirFilter out;
      out.taps = std::move(taps);
      out.sample_rate_hz = fs;
      return out;
    }
    order += 2;
  }
}

FirFilter filter_for_frame_rate(double fps) {
  if (!std::isfinite(fps) || fps <= 0) throw InputError("FIR filter: frame rate " + hz(fps) + " must be positive");
  if (std::fabs(fps - 21) <= 0.5) {
    FirFilter f = havran2005_filter();
    f.sample_rate_hz = fps;
    return f;
  }
  return design_lowpass_filter(fps, fps / 3, 3 * fps / 7);
}

std::vector<double> apply_fir(const FirFilter& filter, const std::vector<double>& signal) {
  const int n = static_cast<int>(filter.taps.size());
  std::vector<double> out;
  if (n == 0) return out;
  out.reserve(signal.size());
  std::vector<double> ring(n);
  int head = 0;
  for (size_t t = 0; t < signal.size(); ++t) {
    if (t > 0) head = head + 1 == n ? 0 : head + 1;
    ring_push(ring.data(), n, head, signal[t], t == 0);
    out.push_back(fir_output(filter.taps.data(), n, ring.data(), head));
  }
  return out;
}

// --- LightTemporalFilter ----------------------------------------------------------------

LightTemporalFilter::LightTemporalFilter(FirFilter filter, TemporalFilterOptions options)
    : filter_(std::move(filter)), options_(options) {
  if (filter_.taps.empty()) throw InputError("temporal filter: the FIR filter has no taps");
  const double sum = std::accumulate(filter_.taps.begin(), filter_.taps.end(), 0.0);
  if (!(sum > 0) || !std::isfinite(sum))
    throw InputError("temporal filter: FIR taps must sum to a positive value (they sum to " + std::to_string(sum) + ")");
  n_taps_ = static_cast<int>(filter_.taps.size());
  power_history_.resize(n_taps_);
}

void LightTemporalFilter::reset() {
  frames_ = 0;
  head_ = 0;
  dir_history_.clear();
  slot_id_.clear();
  slot_seen_.clear();
  free_slots_.clear();
  live_slots_.clear();
  small_slot_.clear();
  large_slot_.clear();
}

int LightTemporalFilter::slot_for(uint64_t id, bool& fresh) {
  int* entry;
  if (id < kSmallIds) {
    if (id >= small_slot_.size()) small_slot_.resize(std::max<size_t>(id + 1, 2 * small_slot_.size()), -1);
    entry = &small_slot_[id];
  } else {
    entry = &large_slot_.try_emplace(id, -1).first->second;
  }
  fresh = *entry < 0;
  if (fresh) {
    int s;
    if (!free_slots_.empty()) {
      s = free_slots_.back();
      free_slots_.pop_back();
    } else {
      s = static_cast<int>(slot_id_.size());
      slot_id_.push_back(0);
      slot_seen_.push_back(-1);
      dir_history_.resize(dir_history_.size() + n_taps_);
    }
    slot_id_[s] = id;
    live_slots_.push_back(s);
    *entry = s;
  }
  return *entry;
}

void LightTemporalFilter::free_slot(int s) {
  const uint64_t id = slot_id_[s];
  if (id < kSmallIds) {
    small_slot_[id] = -1;
  } else {
    large_slot_.erase(id);
  }
  slot_seen_[s] = -1;
  free_slots_.push_back(s);
}

LightList LightTemporalFilter::push(const LightList& frame) {
  const int64_t t = frames_;
  if (t > 0) head_ = head_ + 1 == n_taps_ ? 0 : head_ + 1;
  const double* taps = filter_.taps.data();

  LightList out = frame;
  const std::array<double, 3> power = total_power(frame.lights);

  if (options_.filter_directions) {
    for (Light& light : out.lights) {
      bool fresh = false;
      const int s = slot_for(light.id, fresh);
      if (slot_seen_[s] == t)
        throw InputError("light list frame " + std::to_string(frame.frame) + ": id " + std::to_string(light.id) +
                         " appears twice");
      slot_seen_[s] = t;
      Vec3* ring = dir_history_.data() + static_cast<size_t>(s) * n_taps_;
      ring_push(ring, n_taps_, head_, light.direction, fresh);
      const Vec3 sum = fir_output(taps, n_taps_, ring, head_);
      const double len = length(sum);
      if (len > 1e-9) light.direction = (1.0 / len) * sum;
    }
    // Forget ids that are not in this frame.
    size_t kept = 0;
    for (size_t i = 0; i < live_slots_.size(); ++i) {
      const int s = live_slots_[i];
      if (slot_seen_[s] == t) {
        live_slots_[kept++] = s;
      } else {
        free_slot(s);
      }
    }
    live_slots_.resize(kept);
  }

  ring_push(power_history_.data(), n_taps_, head_, power, t == 0);
  if (options_.filter_power) {
    const std::array<double, 3> filtered = fir_output(taps, n_taps_, power_history_.data(), head_);
    const double n = static_cast<double>(out.lights.size());
    for (int c = 0; c < 3; ++c) {
      const double target = std::max(0.0, filtered[c]);
      if (power[c] != 0) {
        const double scale = target / power[c];
        for (Light& light : out.lights) light.rgb[c] *= scale;
      } else if (n > 0) {
        for (Light& light : out.lights) light.rgb[c] = target / n;
      }
    }
  }
  ++frames_;
  return out;
}

}  // namespace lp
