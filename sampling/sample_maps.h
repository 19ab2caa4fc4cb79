// `lightprobe sample` as one call: a map, or a recorded sequence of maps, through the
// frame pipeline (sampling/frame_pipeline.h), each frame with its lights, its times and
// its accuracy by the CONVENTIONS.md yardstick: the diffuse error by default (~5 ms for a
// 1024x512 map, core/ring_integrals.h), the glossy errors s = 10 and 100 when asked
// (glossy_errors: ~25 ms more, a third of the whole command once its start was cut, issue
// 23), the shadowed error only when --n auto holds it (else `eval sampling` charts it).
// With --n auto the one reference serves both the count and the report.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <functional>
#include <string>
#include <vector>

#include "core/accuracy.h"
#include "core/image_io.h"
#include "core/map_sequence.h"
#include "sampling/frame_pipeline.h"

namespace lp {

struct SampleMapsOptions {
  FramePipelineOptions pipeline;  // its frame_rate_hz also stamps a sequence without timestamps
  ReadMapOptions read;
  // Also score the glossy lobes s = 10 and 100 (sample --glossy-errors); always scored when
  // --n auto holds a glossy measure (or the worst), whose reference has them anyway.
  bool glossy_errors = false;
};

// The report's reference: diffuse; both glossy lobes when asked for or when the auto
// count's measure needs one; shadowed when that measure needs it.
AccuracyOptions report_reference_options(const SampleMapsOptions& options);

struct SampledFrame {
  std::string file;
  LightList list;
  FrameTiming timing;
  LightError error;               // diffuse, glossy {s=10, s=100} (empty when not scored)
  bool target_missed = false;     // --n auto did not reach its target error
  double measured_error = 0;      // --n auto: the frame's error in the target's measure
  nlohmann::json to_json() const;  // the per-frame report of `sample --json`
};

struct SampleMapsResult {
  std::vector<SampledFrame> frames;
  EnvMap last_map;                // the last frame's map (for an overlay)
  int filter_delay_frames = 0;    // lights lag the maps by this many frames
  bool filtering = false;
};

// Frame times: the sequence's timestamps when recorded, else frame / frame_rate_hz from
// 0; a single map is stamped with the current time. Errors from a frame are InputErrors
// naming its file. `frame_done` is called after each frame.
SampleMapsResult sample_maps(const MapSequence& sequence, const SampleMapsOptions& options,
                             const std::function<void()>& frame_done = {});

}  // namespace lp
