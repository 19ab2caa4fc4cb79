#include "core/lazy_libs.h"

#include <dlfcn.h>
#include <fmt/format.h>

#include <cstdlib>
#include <filesystem>
#include <map>
#include <mutex>
#include <stdexcept>

namespace lp::lazy {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> plugin_candidates(const std::string& file, const char* build_path) {
  std::vector<std::string> paths;
  if (const char* dir = std::getenv("LIGHTPROBE_PLUGIN_DIR"); dir && *dir) paths.push_back((fs::path(dir) / file).string());
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    paths.push_back((exe.parent_path() / file).string());
    paths.push_back((exe.parent_path() / ".." / "lib" / file).lexically_normal().string());
  }
  if (build_path) paths.push_back(build_path);
  return paths;
}

#ifdef LIGHTPROBE_LAZY_LIBS_PATH
constexpr const char* kBuildPath = LIGHTPROBE_LAZY_LIBS_PATH;  // where the build wrote it
#else
constexpr const char* kBuildPath = nullptr;
#endif

const PluginTable* load() {
  return static_cast<const PluginTable*>(open_plugin(
      kPluginFile, "lightprobe_lazy_libs", "OpenCV's image and video codecs, mrgingham, ECC", kBuildPath,
      [](const void* t) { return static_cast<const PluginTable*>(t)->version == kPluginVersion; }));
}

const PluginTable& table() {
  static const PluginTable* t = load();  // thread-safe once; a failure is retried next call
  return *t;
}

}  // namespace

void load_plugin() { (void)table(); }

const void* open_plugin(const std::string& file, const char* entry, const std::string& holds, const char* build_path,
                        bool (*accept)(const void* table)) {
  std::string tried, last_error = "not found";
  for (const std::string& path : plugin_candidates(file, build_path)) {
    tried += (tried.empty() ? "" : ", ") + path;
    if (!fs::exists(path)) continue;
    // Never closed: what it returns (decoders, captures, cameras) lives as long as the process.
    void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      last_error = dlerror();
      continue;
    }
    using Entry = const void* (*)();
    auto get = reinterpret_cast<Entry>(dlsym(handle, entry));
    const void* table = get ? get() : nullptr;
    if (table && accept(table)) return table;
    last_error = path + " is not this build's plugin (stale or foreign)";
  }
  throw std::runtime_error(
      fmt::format("cannot load {} ({}): {}; looked in {} (set LIGHTPROBE_PLUGIN_DIR)", file, holds, last_error, tried));
}

void* library_symbol(const char* library, const char* name, const char* what) {
  static std::mutex mutex;
  static std::map<std::string, void*> opened;  // never closed: their functions stay in use
  void* handle = nullptr;
  {
    const std::lock_guard<std::mutex> lock(mutex);
    void*& h = opened[library];
    if (!h) h = dlopen(library, RTLD_NOW | RTLD_LOCAL);
    if (!h) throw std::runtime_error(fmt::format("cannot load {} ({}): {}", what, library, dlerror()));
    handle = h;
  }
  void* symbol = dlsym(handle, name);
  if (!symbol) throw std::runtime_error(fmt::format("{} has no {}: not the {} this was built for", library, name, what));
  return symbol;
}

cv::Mat decode_image(const std::string& bytes) { return table().decode_image(bytes); }

bool encode_image(const std::string& ext, const cv::Mat& image, const std::vector<int>& params,
                  std::vector<uint8_t>& bytes) {
  return table().encode_image(ext, image, params, bytes);
}

std::unique_ptr<VideoCapture> make_video_capture() { return std::unique_ptr<VideoCapture>(table().new_video_capture()); }

int find_chessboard_mrgingham(std::vector<cv::Point2d>& corners, int gridn, const cv::Mat& image, int pyramid_level) {
  return table().find_chessboard_mrgingham(corners, gridn, image, pyramid_level);
}

double find_transform_ecc(const cv::Mat& templ, const cv::Mat& input, cv::Mat& warp, int motion,
                          cv::TermCriteria criteria, int gauss_filt_size) {
  return table().find_transform_ecc(templ, input, warp, motion, criteria, gauss_filt_size);
}

}  // namespace lp::lazy
