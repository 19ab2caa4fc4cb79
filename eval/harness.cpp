#include "eval/harness.h"

#include <algorithm>
#include <filesystem>

#include "eval/synthetic_scene.h"
#include "hdr/synthetic_bracket.h"

namespace lp {

EnvMap map_or_scene(const std::string& path, int scene_width) {
  if (path == "scene") return render_scene(describe_scene(), Layout::LatLong, scene_width, scene_width / 2);
  return read_envmap(path);
}

RgbImage radiance_or_scene(const std::string& path) {
  if (path == "scene") return image_from_envmap(render_scene(describe_scene(), Layout::LatLong, 512, 256));
  return read_rgb_image(path);
}

std::string map_label(const std::string& path) {
  return path == "scene" ? "scene" : std::filesystem::path(path).stem().string();
}

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values.empty() ? 0 : values[values.size() / 2];
}

ProgressSteps::ProgressSteps(const EvalProgress& progress, size_t total) : progress_(progress), total_(total) {
  if (progress_) progress_(0, total_);
}

void ProgressSteps::advance(size_t steps) {
  done_ += steps;
  if (progress_) progress_(done_, total_);
}

}  // namespace lp
