// What the `eval` harnesses share: their inputs (a map file, or "scene" for the procedural
// scene), their progress callback, the labels of their tables and the median they report.
#pragma once

#include <cstddef>
#include <functional>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/image_io.h"

namespace lp {

// Progress of a harness, from the calling thread: (steps done, steps in all), first with
// done = 0 before any work, then after (or before, as the harness says) each step.
using EvalProgress = std::function<void(size_t done, size_t total)>;

// A map file, or "scene": the procedural scene rendered at latlong width x width / 2.
EnvMap map_or_scene(const std::string& path, int scene_width);
// A radiance image file as stored, or "scene" (latlong 512x256 as an image).
RgbImage radiance_or_scene(const std::string& path);
// "scene", or the file name without folder and extension (labels of tables and charts).
std::string map_label(const std::string& path);

// The upper median (element size / 2 after sorting); 0 for no values.
double median(std::vector<double> values);

// Reports progress to an optional callback: total known up front, one step at a time.
class ProgressSteps {
 public:
  ProgressSteps(const EvalProgress& progress, size_t total);
  void advance(size_t steps = 1);

 private:
  const EvalProgress& progress_;
  size_t done_ = 0, total_;
};

}  // namespace lp
