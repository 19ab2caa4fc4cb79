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
}

int FramePipeline::delay_frames() const { return filter_ ? filter_->filter().delay_frames() : 0; }

LightList FramePipeline::process(const EnvMap& map, int64_t frame, double timestamp) {
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
    const AccuracyReference reference = make_accuracy_reference(map, reference_options_for(options_.auto_options.measure));
    AutoCountResult r = tracker_->update(*sampler_, reference);
    count_ = {int(r.lights.size()), true, r.error, r.reached};
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
  return list;
}

}  // namespace lp
