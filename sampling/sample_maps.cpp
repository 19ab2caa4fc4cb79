#include "sampling/sample_maps.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <chrono>

#include "core/error.h"

namespace lp {

nlohmann::json SampledFrame::to_json() const {
  return {{"file", file},
          {"frame", list.frame},
          {"lights", list.lights.size()},
          {"prepare_seconds", timing.prepare_ms / 1e3},
          {"place_seconds", timing.place_ms / 1e3},
          {"temporal_seconds", timing.temporal_ms / 1e3},
          {"diffuse_error", error.diffuse},
          {"glossy10_error", error.glossy.empty() ? nlohmann::json() : nlohmann::json(error.glossy.at(0))},
          {"glossy100_error", error.glossy.empty() ? nlohmann::json() : nlohmann::json(error.glossy.at(1))}};
}

AccuracyOptions report_reference_options(const SampleMapsOptions& options) {
  const bool auto_count = options.pipeline.auto_count;
  const AccuracyOptions needed = reference_options_for(options.pipeline.auto_options.measure);
  AccuracyOptions ao;  // defaults: both lobes, the caps
  ao.shadowed = auto_count && needed.shadowed;
  if (!options.glossy_errors && !(auto_count && !needed.glossy_exponents.empty())) ao.glossy_exponents.clear();
  return ao;
}

SampleMapsResult sample_maps(const MapSequence& sequence, const SampleMapsOptions& options,
                             const std::function<void()>& frame_done) {
  FramePipeline pipeline(options.pipeline);
  const AccuracyOptions ao = report_reference_options(options);
  const ErrorMeasure measure = options.pipeline.auto_options.measure;
  SampleMapsResult result;
  const size_t n = sequence.files.size();
  for (size_t f = 0; f < n; ++f) {
    const std::string& file = sequence.files[f];
    EnvMap map = read_envmap(file, options.read);
    const double now =
        sequence.timestamps_s ? (*sequence.timestamps_s)[f]
        : sequence.is_sequence()
            ? double(f) / options.pipeline.frame_rate_hz
            : std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    SampledFrame frame;
    frame.file = file;
    const AccuracyReference reference = make_accuracy_reference(map, ao);
    try {
      frame.list = pipeline.process(map, int64_t(f), now, options.pipeline.auto_count ? &reference : nullptr);
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}", file, e.what()));
    }
    frame.timing = pipeline.last_timing();
    frame.error = light_error(reference, frame.list.lights);
    if (options.pipeline.auto_count) {
      frame.measured_error = measured_error(frame.error, ao, measure);
      frame.target_missed = frame.measured_error > options.pipeline.auto_options.target_error;
    }
    result.frames.push_back(std::move(frame));
    if (f + 1 == n) result.last_map = std::move(map);
    if (frame_done) frame_done();
  }
  result.filter_delay_frames = pipeline.delay_frames();
  result.filtering = pipeline.filtering();
  return result;
}

}  // namespace lp
