// LibRaw and Exiv2, loaded on first use. Camera RAW files (LibRaw, with libjpeg, LittleCMS
// and OpenMP) and the EXIF exposure time of JPEG brackets (Exiv2, with expat) are read only
// by `hdr fuse` and what reads brackets, yet every command, even `--version`, loaded those
// 6 libraries at start (~5 ms). They live in a plugin instead (liblightprobe_camera_files.so,
// hdr/plugin/), which the first RAW file or EXIF read loads; it is found where
// core/lazy_libs.h looks for its plugin.
//
// The plugin returns plain data and messages; the callers (raw_input.cpp, bracket.cpp) turn
// them into InputErrors naming the file, as they did.
//
// Internal to hdr/: only raw_input.cpp, bracket.cpp and the plugin include it.
// Exiv2 also reads embedded ICC profiles (bracket.cpp warns about the ones it cannot apply).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace lp::detail {

// A RAW file developed by LibRaw (raw_input.h read_camera_raw's settings: 16 bit, linear,
// camera white balance, sRGB primaries, no auto-brightening).
struct DevelopedRaw {
  enum class Status { Ok, Failed, SensorTooLarge };
  Status status = Status::Failed;
  std::string message;          // Failed: "LibRaw cannot <step> it (<LibRaw's reason>)" or what was unexpected
  int sensor_width = 0, sensor_height = 0;  // from the metadata, before unpacking
  int width = 0, height = 0, colors = 0;    // Ok: the developed image, colors 1 or 3
  std::vector<uint16_t> samples;            // Ok: width * height * colors, row-major
  double shutter_seconds = 0;               // as recorded; 0 when none
  double iso = 0, f_number = 0;             // as recorded; 0 when none
  // Developed as stored (LibRaw's user_flip 0); the file's orientation as EXIF's 1-8.
  int orientation = 1;
};

// EXIF exposure time: Exif.Photo.ExposureTime, Exif.Image.ExposureTime, then the APEX
// Exif.Photo.ShutterSpeedValue.
struct ExifExposure {
  enum class Status { Found, Absent, Failed };
  Status status = Status::Absent;
  double seconds = 0;
  std::string message;  // Failed: "cannot open to read EXIF" or "cannot read EXIF: <Exiv2's reason>"
  // What else sets the exposure, where recorded (Exiv2's isoSpeed and fNumber, maker notes
  // included), else 0; read whether or not a time was found.
  double iso = 0, f_number = 0;
};

// What the plugin exports (its one symbol, `lightprobe_camera_files`, returns it). The
// version changes whenever the table or the structs above do.
struct CameraFilesPluginTable {
  int version;
  // `sensor_fits(width, height)`: whether the sensor may be unpacked (core/limits.h);
  // SensorTooLarge otherwise, before anything is allocated for it.
  DevelopedRaw (*develop_raw)(const std::string& path, bool (*sensor_fits)(int width, int height));
  ExifExposure (*exif_exposure)(const std::string& path);
  // The file's embedded ICC profile (JPEG, PNG, TIFF), empty when it has none or Exiv2
  // cannot read the file (the image reader reports that).
  std::string (*icc_profile)(const std::string& path);
};
inline constexpr int kCameraFilesPluginVersion = 5;
inline constexpr const char* kCameraFilesPluginFile = "liblightprobe_camera_files.so";

// The plugin's table, loaded once; throws std::runtime_error when it cannot be loaded.
const CameraFilesPluginTable& camera_files_plugin();

}  // namespace lp::detail
