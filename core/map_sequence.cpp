#include "core/map_sequence.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "core/error.h"
#include "core/file_io.h"
#include "core/timestamps.h"

namespace lp {

namespace {

namespace fs = std::filesystem;

bool is_map_file(const fs::path& p) { return is_radiance_file(p.string()); }

bool is_image_file(const fs::path& p) { return is_radiance_file(p.string()) || is_camera_image_file(p.string()); }

// The files named, a directory standing for the files inside it that `keep` accepts.
std::vector<std::string> expand(const std::vector<std::string>& inputs, bool (*keep)(const fs::path&), const char* what) {
  std::vector<std::string> files;
  for (const std::string& in : inputs) {
    std::error_code ec;
    if (fs::is_directory(in, ec)) {
      std::vector<std::string> found;
      for (const auto& entry : fs::directory_iterator(in))
        if (entry.is_regular_file() && keep(entry.path())) found.push_back(entry.path().string());
      std::sort(found.begin(), found.end(), [](const std::string& a, const std::string& b) {
        return frame_name_less(fs::path(a).filename().string(), fs::path(b).filename().string());
      });
      if (found.empty()) throw InputError(fmt::format("{}: directory holds no {}", in, what));
      files.insert(files.end(), found.begin(), found.end());
    } else {
      files.push_back(in);
    }
  }
  return files;
}

std::vector<double> read_sequence_timestamps(const fs::path& path, size_t frames) {
  std::vector<double> times = read_timestamps(path.string());
  if (times.size() != frames)
    throw InputError(fmt::format("{}: {} times for {} maps", path.string(), times.size(), frames));
  return times;
}

}  // namespace

MapSequence find_map_sequence(const std::vector<std::string>& inputs) {
  MapSequence seq;
  seq.files = expand(inputs, is_map_file, ".exr/.hdr/.pfm maps");
  std::error_code ec;
  if (inputs.size() == 1 && fs::is_directory(inputs[0], ec)) {
    const fs::path path = fs::path(inputs[0]) / "timestamps.txt";
    if (fs::exists(path, ec)) seq.timestamps_s = read_sequence_timestamps(path, seq.files.size());
  }
  return seq;
}

std::vector<std::string> find_images(const std::vector<std::string>& inputs) {
  return expand(inputs, is_image_file, "images");
}

}  // namespace lp
