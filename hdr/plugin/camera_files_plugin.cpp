// The plugin of hdr/camera_files_plugin.h: the only code linked with LibRaw and Exiv2. The
// reading moved here from raw_input.cpp and bracket.cpp unchanged.
#include <exiv2/exiv2.hpp>
#include <libraw/libraw.h>

#include <cmath>
#include <cstring>
#include <memory>

#include "hdr/camera_files_plugin.h"

namespace lp::detail {
namespace {

std::string trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r\n"), e = s.find_last_not_of(" \t\r\n");
  return b == std::string::npos ? std::string() : s.substr(b, e - b + 1);
}

DevelopedRaw develop_raw(const std::string& path, bool (*sensor_fits)(int, int)) {
  DevelopedRaw out;
  auto raw = std::make_unique<LibRaw>();  // large: keep it off the stack
  auto failed = [&](const char* step, int rc) {
    out.status = DevelopedRaw::Status::Failed;
    out.message = std::string("LibRaw cannot ") + step + " it (" + libraw_strerror(rc) + ")";
    return out;
  };
  int rc = raw->open_file(path.c_str());
  if (rc != LIBRAW_SUCCESS) return failed("open", rc);
  // open_file reads only the metadata: check the sensor size before unpack allocates it.
  out.sensor_width = raw->imgdata.sizes.raw_width;
  out.sensor_height = raw->imgdata.sizes.raw_height;
  if (!sensor_fits(out.sensor_width, out.sensor_height)) {
    out.status = DevelopedRaw::Status::SensorTooLarge;
    return out;
  }
  auto& params = raw->imgdata.params;
  params.output_bps = 16;
  params.gamm[0] = params.gamm[1] = 1.0;
  params.no_auto_bright = 1;
  params.use_camera_wb = 1;
  params.output_color = 1;  // sRGB primaries, linear with the gamma above
  // As stored: the caller turns frames as their orientation says where that is right (a
  // bracket whose tags agree), and leaves a fisheye's, which a camera pointing up makes noise.
  params.user_flip = 0;
  // dcraw's flip (bit 2: exchange the axes, then bit 0: mirror x, bit 1: mirror y; LibRaw
  // sets 0, 3, 5 or 6 from the file) as EXIF's Orientation.
  static constexpr int kExifOrientationOfFlip[8] = {1, 2, 4, 3, 5, 8, 6, 7};
  out.orientation = kExifOrientationOfFlip[raw->imgdata.sizes.flip & 7];
  if ((rc = raw->unpack()) != LIBRAW_SUCCESS) return failed("unpack", rc);
  if ((rc = raw->dcraw_process()) != LIBRAW_SUCCESS) return failed("develop", rc);
  std::unique_ptr<libraw_processed_image_t, void (*)(libraw_processed_image_t*)> img(
      raw->dcraw_make_mem_image(&rc), &LibRaw::dcraw_clear_mem);
  if (!img || rc != LIBRAW_SUCCESS) return failed("develop", rc);
  if (img->type != LIBRAW_IMAGE_BITMAP || img->bits != 16 || (img->colors != 3 && img->colors != 1)) {
    out.message = "LibRaw produced an unexpected image (" + std::to_string(img->colors) + " colours, " +
                  std::to_string(img->bits) + " bits)";
    return out;
  }
  out.width = img->width;
  out.height = img->height;
  out.colors = img->colors;
  out.samples.resize(size_t(out.width) * size_t(out.height) * size_t(out.colors));
  std::memcpy(out.samples.data(), img->data, out.samples.size() * 2);
  const auto& other = raw->imgdata.other;
  auto positive = [](float v) { return std::isfinite(v) && v > 0 ? double(v) : 0.0; };
  out.shutter_seconds = positive(other.shutter);
  out.iso = positive(other.iso_speed);
  out.f_number = positive(other.aperture);
  out.status = DevelopedRaw::Status::Ok;
  return out;
}

// The file opened by Exiv2 with its metadata read, or null. Exiv2 writes warnings to stderr
// by default; library code prints nothing, so it is muted first.
Exiv2::Image::AutoPtr open_with_metadata(const std::string& path) {
  static const bool muted = [] {
    Exiv2::LogMsg::setLevel(Exiv2::LogMsg::mute);
    return true;
  }();
  (void)muted;
  auto image = Exiv2::ImageFactory::open(path);
  if (image.get() != nullptr) image->readMetadata();
  return image;
}

// The first value of a metadatum as a positive number, else 0.
double positive_value(const Exiv2::ExifData& exif, Exiv2::ExifData::const_iterator it) {
  if (it == exif.end() || it->count() == 0) return 0;
  const double v = it->toFloat(0);
  return std::isfinite(v) && v > 0 ? double(v) : 0;
}

ExifExposure exif_exposure(const std::string& path) {
  ExifExposure out;
  try {
    auto image = open_with_metadata(path);
    if (image.get() == nullptr) {
      out.status = ExifExposure::Status::Failed;
      out.message = "cannot open to read EXIF";
      return out;
    }
    const Exiv2::ExifData& exif = image->exifData();
    out.iso = positive_value(exif, Exiv2::isoSpeed(exif));
    out.f_number = positive_value(exif, Exiv2::fNumber(exif));
    for (const char* key : {"Exif.Photo.ExposureTime", "Exif.Image.ExposureTime"}) {
      const auto it = exif.findKey(Exiv2::ExifKey(key));
      if (it == exif.end() || it->count() == 0) continue;
      if (it->count() != 1) {  // a writer's mistake: taking the first value read 1/8 s as 1 s
        out.status = ExifExposure::Status::Failed;
        out.message = std::string("EXIF ") + key + " holds " + std::to_string(it->count()) + " values (" +
                      trim(it->value().toString()) + "), not one exposure time";
        return out;
      }
      const Exiv2::Rational r = it->toRational(0);
      if (r.second != 0 && r.first > 0) {
        out.status = ExifExposure::Status::Found;
        out.seconds = double(r.first) / double(r.second);
        return out;
      }
    }
    const auto it = exif.findKey(Exiv2::ExifKey("Exif.Photo.ShutterSpeedValue"));
    if (it != exif.end() && it->count() > 0) {
      const Exiv2::Rational r = it->toRational(0);  // APEX: t = 2^-Tv
      if (r.second != 0) {
        out.status = ExifExposure::Status::Found;
        out.seconds = std::exp2(-double(r.first) / double(r.second));
      }
    }
    return out;
  } catch (const Exiv2::AnyError& e) {
    out.status = ExifExposure::Status::Failed;
    out.message = "cannot read EXIF: " + trim(e.what());
    return out;
  }
}

std::string icc_profile(const std::string& path) {
  try {
    auto image = open_with_metadata(path);
    if (image.get() == nullptr || !image->iccProfileDefined()) return {};
    const Exiv2::DataBuf* icc = image->iccProfile();
    return std::string(reinterpret_cast<const char*>(icc->pData_), size_t(icc->size_));
  } catch (const Exiv2::AnyError&) {
    return {};
  }
}

constexpr CameraFilesPluginTable kTable{kCameraFilesPluginVersion, &develop_raw, &exif_exposure, &icc_profile};

}  // namespace
}  // namespace lp::detail

extern "C" __attribute__((visibility("default"))) const void* lightprobe_camera_files() { return &lp::detail::kTable; }
