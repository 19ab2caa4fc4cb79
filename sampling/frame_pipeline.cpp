#include "sampling/frame_pipeline.h"

#include <chrono>
#include <cmath>

#include "core/error.h"
#include "sampling/clustering.h"

namespace lp {

namespace {
double ms_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

FramePipeline::FramePipeline(const FramePipelineOptions& options) : options_(options) {
  if (!options.auto_count && options.count <= 0) throw InputError("--n must be positive");
  if (options.cluster_max_lights < 0) throw InputError("--cluster must be >= 0");
  if (options.budget.budget_ms != 0 && !options.auto_count)
    throw InputError("--frame-budget-ms caps the count of --n auto: give --n auto");
  reset();
}

void FramePipeline::reset() {
  sampler_ = make_sampler(options_.method, options_.sampler);
  const bool filter = options_.filter == FilterMode::On ||
                      (options_.filter == FilterMode::Auto && options_.method == Method::Hemigon);
  filter_.reset();
  if (filter) filter_.emplace(filter_for_frame_rate(options_.frame_rate_hz));
  tracker_.reset();
  if (options_.auto_count) tracker_.emplace(options_.auto_options, options_.hysteresis);
  budget_.reset();
  if (options_.budget.budget_ms != 0) {
    FrameBudgetOptions b = options_.budget;
    b.min_count = options_.auto_options.min_count;
    b.max_count = options_.auto_options.max_count;
    budget_.emplace(b);
  }
}

int FramePipeline::delay_frames() const { return filter_ ? filter_->filter().delay_frames() : 0; }

LightList FramePipeline::process(const EnvMap& map, int64_t frame, double timestamp, const AccuracyReference* reference) {
  auto t0 = std::chrono::steady_clock::now();
  sampler_->prepare(map);
  timing_.prepare_ms = ms_since(t0);

  t0 = std::chrono::steady_clock::now();
  LightList list;
  list.frame = frame;
  list.timestamp = timestamp;
  list.method = std::string(to_string(options_.method));
  list.units = map.units;
  if (tracker_) {
    AccuracyReference built;
    if (!reference) built = make_accuracy_reference(map, reference_options_for(options_.auto_options.measure));
    if (budget_) tracker_->limit(budget_->cap());  // the search goes no further than the budget affords
    AutoCountResult r = tracker_->update(*sampler_, reference ? *reference : built);
    count_ = {int(r.lights.size()), true, r.error, r.reached};
    count_.budget_limited =
        budget_ && !r.reached && budget_->cap() < options_.auto_options.max_count && r.requested >= budget_->cap();
    list.lights = std::move(r.lights);
  } else {
    list.lights = sampler_->place(options_.count);
    count_ = {int(list.lights.size()), false, NAN, true};
  }
  timing_.place_ms = ms_since(t0);

  t0 = std::chrono::steady_clock::now();
  if (filter_) list = filter_->push(list);
  if (options_.cluster_max_lights > 0) {
    ClusterOptions co;
    co.upper_hemisphere_only = options_.sampler.upper_only;
    list.lights = cluster_lights(list.lights, options_.cluster_max_lights, co);
  }
  timing_.temporal_ms = ms_since(t0);
  if (budget_) count_.budget_cap = budget_->update(count_.count, timing_.prepare_ms + timing_.place_ms + timing_.temporal_ms);
  return list;
}

}  // namespace lp
