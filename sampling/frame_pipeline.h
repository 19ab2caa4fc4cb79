// The per-frame back end of a live probe: map -> lights, with the temporal processing a
// video needs. One object per stream; it keeps the state that makes frames coherent
// (the sampler's caches and incremental tree, the FIR histories, the auto-count state).
//
//   prepare + place (or the auto count with hysteresis)
//   -> FIR low-pass on total power and on each light's direction (Havran 2005 3.3)
//   -> optional clustering to at most Q lights (Havran 2005 4.3)
#pragma once

#include <memory>
#include <optional>

#include "core/accuracy.h"
#include "sampling/auto_count.h"
#include "sampling/frame_budget.h"
#include "sampling/sampler.h"
#include "sampling/temporal_filter.h"

namespace lp {

enum class FilterMode { Auto, On, Off };

struct FramePipelineOptions {
  Method method = Method::Hemigon;
  SamplerOptions sampler;
  int count = 256;                  // lights per frame (ignored with auto_count)
  bool auto_count = false;          // --n auto: fewest lights reaching the target error
  AutoCountOptions auto_options;
  AutoCountHysteresis hysteresis;
  FrameBudgetOptions budget;        // --frame-budget-ms (needs auto_count): caps the count
                                    // (its min/max counts are taken from auto_options)
  // Auto: the FIR filters run for hemigon (as in Havran 2005) and not for the others;
  // q2tree is stable by construction, pharr's global jumps are what the atlas shows.
  FilterMode filter = FilterMode::Auto;
  double frame_rate_hz = 21;        // the filter is re-designed for other rates
  int cluster_max_lights = 0;       // 0: no clustering
};

// The light count of the last frame: fixed, or what the auto count chose and why.
struct FrameCount {
  int count = 0;              // lights placed (before clustering)
  bool automatic = false;     // --n auto
  double error = 0;           // automatic: the chosen count's error in the measure (NaN for a fixed n)
  bool reached = true;        // automatic: false when even max_count missed the target
  bool budget_limited = false;  // the frame budget placed fewer lights than the target asked
  int budget_cap = 0;           // with a budget: the most lights it allows the next frame
};

struct FrameTiming {
  double prepare_ms = 0, place_ms = 0, temporal_ms = 0;
};

class FramePipeline {
 public:
  explicit FramePipeline(const FramePipelineOptions& options);
  // Lights for the next frame of the stream. With auto_count the accuracy reference of
  // the map is built here (only what the measure needs), which dominates such frames' cost;
  // a caller that builds one anyway (`sample`'s report) passes it as `reference` (of this
  // map, holding the measure) and it is not built twice.
  LightList process(const EnvMap& map, int64_t frame, double timestamp, const AccuracyReference* reference = nullptr);
  // Frames by which the output lags the input (0 without filtering).
  int delay_frames() const;
  bool filtering() const { return filter_.has_value(); }
  const FrameTiming& last_timing() const { return timing_; }
  const FrameCount& last_count() const { return count_; }
  void reset();

 private:
  FramePipelineOptions options_;
  std::unique_ptr<Sampler> sampler_;
  std::optional<LightTemporalFilter> filter_;
  std::optional<AutoCountTracker> tracker_;
  std::optional<FrameBudget> budget_;
  FrameTiming timing_;
  FrameCount count_;
};

}  // namespace lp
