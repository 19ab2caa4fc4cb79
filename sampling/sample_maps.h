// `lightprobe sample` as one call: a map, or a recorded sequence of maps, through the
// frame pipeline (sampling/frame_pipeline.h), each frame with its lights, its times and
// its accuracy by the CONVENTIONS.md yardstick: diffuse and glossy, ~20 ms for a 1024x512
// map on 2 cores (core/ring_integrals.h; 200 ms before it), a tenth of what the command's
// start costs; the shadowed error, which would add ~35 ms a frame, only when --n auto holds
// it (else `eval sampling` charts it).
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
};

struct SampledFrame {
  std::string file;
  LightList list;
  FrameTiming timing;
  LightError error;               // diffuse, glossy {s=10, s=100}
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
