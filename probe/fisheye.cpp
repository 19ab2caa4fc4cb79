#include "probe/fisheye.h"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <filesystem>
#include <limits>

#include "calib/lens_model.h"
#include "calib/camera_model.h"
#include "core/error.h"
#include "core/file_io.h"

namespace lp {
namespace {

constexpr double kDeg = M_PI / 180.0;

inline double distort_theta(const std::array<double, 4>& k, double t) {
  const double t2 = t * t;
  return t * (1 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
}
inline double distort_theta_derivative(const std::array<double, 4>& k, double t) {
  const double t2 = t * t;
  return 1 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3])));
}

// Bilinear lookup of a latlong / hemisphere map (nearest for healpix); false when the
// direction has no valid pixel under it.
bool sample_map(const EnvMap& map, Vec3 d, float* rgb) {
  if (map.layout == Layout::Healpix) {
    const auto p = pixel_at(map, d);
    if (!p || !map.is_valid(*p)) return false;
    for (int k = 0; k < 3; ++k) rgb[k] = map.rgb[3 * *p + k];
    return true;
  }
  const double theta = zenith_of(d), phi = azimuth_of(d);
  const double theta_span = map.layout == Layout::LatLong ? M_PI : M_PI / 2;
  if (theta > theta_span) return false;
  const double u = phi * map.width / (2 * M_PI) - 0.5;
  double v = theta * map.height / theta_span - 0.5;
  v = std::clamp(v, 0.0, double(map.height - 1));
  const double uf = std::floor(u);
  const double fu = u - uf;
  const int u0 = ((int(uf) % map.width) + map.width) % map.width, u1 = (u0 + 1) % map.width;
  const int v0 = std::min(int(v), map.height - 1), v1 = std::min(v0 + 1, map.height - 1);
  const double fv = v - v0;
  const size_t i00 = size_t(v0) * map.width + u0, i10 = size_t(v0) * map.width + u1;
  const size_t i01 = size_t(v1) * map.width + u0, i11 = size_t(v1) * map.width + u1;
  if (!map.is_valid(i00) || !map.is_valid(i10) || !map.is_valid(i01) || !map.is_valid(i11)) return false;
  for (int k = 0; k < 3; ++k)
    rgb[k] = float((1 - fv) * ((1 - fu) * map.rgb[3 * i00 + k] + fu * map.rgb[3 * i10 + k]) +
                   fv * ((1 - fu) * map.rgb[3 * i01 + k] + fu * map.rgb[3 * i11 + k]));
  return true;
}

std::string size_text(int w, int h) { return std::to_string(w) + "x" + std::to_string(h); }

}  // namespace

Mat3 default_fisheye_world_from_camera() { return Mat3{{0, -1, 0, 1, 0, 0, 0, 0, 1}}; }

FisheyeModel equidistant_fisheye(int width, int height, double fov_deg) {
  if (width <= 0 || height <= 0) throw InputError("fisheye size must be positive, got " + size_text(width, height));
  if (!(fov_deg > 0 && fov_deg <= 360)) throw InputError("fisheye field of view must be in (0, 360] degrees");
  FisheyeModel m;
  m.width = width;
  m.height = height;
  const double radius = std::min(width, height) / 2.0;
  const double half = fov_deg / 2 * kDeg;
  m.fx = m.fy = radius / half;
  m.cx = width / 2.0 - 0.5;  // OpenCV: pixel centres at integers
  m.cy = height / 2.0 - 0.5;
  m.max_theta_deg = fov_deg / 2;
  return m;
}

FisheyeModel read_fisheye_yaml(const std::string& path) {
  if (lower_extension(path) == ".cameramodel")
    throw InputError(path + ": mrcal models are not read yet; export OpenCV YAML");
  cv::FileStorage fs = open_opencv_storage(path);
  auto need = [&](const char* key) {
    cv::FileNode n = fs[key];
    if (n.empty()) throw InputError(path + ": missing key " + key);
    return n;
  };
  std::string dist_model;
  try {
    need("distortion_model") >> dist_model;
  } catch (const cv::Exception&) {
    throw InputError(path + ": distortion_model is not a string");
  }
  const std::string kb_form = lens_type_info(LensType::KannalaBrandt).opencv_distortion_model;
  if (dist_model != kb_form)
    throw InputError(path + ": distortion_model is '" + dist_model + "', only '" + kb_form +
                     "' (Kannala-Brandt, cv::fisheye) is read here");
  FisheyeModel m;
  cv::Mat K, D;
  try {  // OpenCV throws on a node of the wrong kind (found by fuzz_opencv_yaml)
    need("image_width") >> m.width;
    need("image_height") >> m.height;
    read_yaml_matrix(need("camera_matrix"), path, "camera_matrix", 9, &K);
    read_yaml_matrix(need("distortion_coefficients"), path, "distortion_coefficients", 4, &D);
  } catch (const cv::Exception&) {
    throw InputError(path + ": image_width, image_height must be numbers and camera_matrix, "
                            "distortion_coefficients OpenCV matrices");
  }
  if (K.rows != 3 || K.cols != 3) throw InputError(path + ": camera_matrix is not 3x3");
  if (D.total() != 4) throw InputError(path + ": fisheye distortion_coefficients must hold 4 values, has " +
                                       std::to_string(D.total()));
  K.convertTo(K, CV_64F);
  D.convertTo(D, CV_64F);
  m.fx = K.at<double>(0, 0);
  m.fy = K.at<double>(1, 1);
  m.cx = K.at<double>(0, 2);
  m.cy = K.at<double>(1, 2);
  for (int i = 0; i < 4; ++i) m.k[i] = D.at<double>(int(i));
  if (m.width <= 0 || m.height <= 0 || !(m.fx > 0) || !(m.fy > 0))
    throw InputError(path + ": image size and focal lengths must be positive");
  if (std::abs(K.at<double>(0, 1)) > 1e-9 * m.fx)
    throw InputError(path + ": camera_matrix has skew, which is not supported");
  return m;
}

void write_fisheye_yaml(const std::string& path, const FisheyeModel& model) {
  const int format = lower_extension(path) == ".xml" ? cv::FileStorage::FORMAT_XML : cv::FileStorage::FORMAT_YAML;
  cv::FileStorage fs(path, cv::FileStorage::WRITE | cv::FileStorage::MEMORY | format);
  fs << "image_width" << model.width << "image_height" << model.height;
  cv::Mat K = (cv::Mat_<double>(3, 3) << model.fx, 0, model.cx, 0, model.fy, model.cy, 0, 0, 1);
  cv::Mat D = (cv::Mat_<double>(4, 1) << model.k[0], model.k[1], model.k[2], model.k[3]);
  fs << "camera_matrix" << K << "distortion_coefficients" << D << "distortion_model"
     << lens_type_info(LensType::KannalaBrandt).opencv_distortion_model;
  write_file_atomically(path, fs.releaseAndGetString());
}

Vec3 fisheye_unproject(const FisheyeModel& model, double x, double y) {
  const double a = (x - model.cx) / model.fx, b = (y - model.cy) / model.fy;
  const double theta_d = std::hypot(a, b);
  Vec3 cam{0, 0, 1};
  if (theta_d > 0) {
    double t = theta_d;
    bool ok = false;
    for (int it = 0; it < 30; ++it) {
      const double f = distort_theta(model.k, t) - theta_d;
      const double df = distort_theta_derivative(model.k, t);
      if (!(df > 0)) break;
      const double step = f / df;
      t -= step;
      if (std::abs(step) < 1e-12) {
        ok = true;
        break;
      }
    }
    if (!ok || !(t >= 0)) {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      return {nan, nan, nan};
    }
    const double s = std::sin(t) / theta_d;
    cam = {s * a, s * b, std::cos(t)};
  }
  return model.world_from_camera * cam;
}

std::optional<ImagePoint> fisheye_project(const FisheyeModel& model, Vec3 direction) {
  const Vec3 c = transpose(model.world_from_camera) * direction;
  const double rho = std::hypot(c.x, c.y);
  const double theta = std::atan2(rho, c.z);
  if (!(theta <= model.max_theta_deg * kDeg)) return std::nullopt;
  if (rho == 0) return ImagePoint{model.cx, model.cy};
  const double s = distort_theta(model.k, theta) / rho;
  return ImagePoint{model.fx * s * c.x + model.cx, model.fy * s * c.y + model.cy};
}

RemapTable fisheye_remap(const FisheyeModel& model, Layout layout, int width, int height) {
  return remap_table(layout, width, height, model.width, model.height,
                     [&](Vec3 d) -> std::optional<std::array<double, 2>> {
                       const auto p = fisheye_project(model, d);
                       if (!p) return std::nullopt;
                       return std::array<double, 2>{p->x + 0.5, p->y + 0.5};  // remap convention
                     });
}

EnvMap unwrap_fisheye(const RgbImage& image, const FisheyeModel& model, Layout layout, int width, int height,
                      const FisheyeUnwrapOptions& options, FisheyeUnwrapReport* report) {
  if (image.width != model.width || image.height != model.height)
    throw InputError("camera model is for " + size_text(model.width, model.height) + ", image is " +
                     size_text(image.width, image.height));
  const RemapTable table = fisheye_remap(model, layout, width, height);
  RgbImage out = apply_remap(image, table, options.remap);
  EnvMap map = make_envmap(layout, width, height);
  map.units = image.units;
  map.rgb = std::move(out.rgb);
  map.valid = std::move(out.valid);
  FisheyeUnwrapReport rep;
  for (size_t i = 0; i < map.pixel_count(); ++i)
    if (map.is_valid(i)) rep.valid_solid_angle += pixel_solid_angle(map, i);
  if (options.fill.method != FillMethod::None && !map.valid.empty()) fill_invalid(map, options.fill, &rep.fill);
  if (report) *report = rep;
  return map;
}

std::string orientation_not_applied_note(const std::string& file, int orientation) {
  return fmt::format("{}: its EXIF Orientation ({}) is not applied: a fisheye is unwrapped in its sensor's frame (a "
                     "camera pointing up records an arbitrary one; --rotation turns the probe)",
                     file, orientation);
}

std::string fused_turn_undone_note(const std::string& file, int orientation) {
  return fmt::format("{}: fused turned by its frames' EXIF Orientation ({}); turned back: a fisheye is unwrapped in "
                     "its sensor's frame (--rotation turns the probe)",
                     file, orientation);
}

RgbImage render_fisheye(const EnvMap& map, const FisheyeModel& model, int samples_per_edge) {
  if (samples_per_edge < 1) throw InputError("render_fisheye: samples_per_edge must be at least 1");
  if (model.width <= 0 || model.height <= 0) throw InputError("render_fisheye: camera model has no image size");
  RgbImage im;
  im.width = model.width;
  im.height = model.height;
  im.units = map.units;
  im.rgb.assign(size_t(im.width) * im.height * 3, 0.0f);
  const int k = samples_per_edge;
  const double max_theta = model.max_theta_deg * kDeg;
  tbb::parallel_for(tbb::blocked_range<int>(0, im.height), [&](const tbb::blocked_range<int>& rows) {
    for (int y = rows.begin(); y < rows.end(); ++y)
      for (int x = 0; x < im.width; ++x) {
        double acc[3] = {0, 0, 0};
        for (int sy = 0; sy < k; ++sy)
          for (int sx = 0; sx < k; ++sx) {
            // OpenCV coordinates: pixel x spans [x - 0.5, x + 0.5].
            const double px = x - 0.5 + (sx + 0.5) / k, py = y - 0.5 + (sy + 0.5) / k;
            const Vec3 d = fisheye_unproject(model, px, py);
            if (!(std::isfinite(d.x))) continue;
            if (angle_between(d, model.world_from_camera * Vec3{0, 0, 1}) > max_theta) continue;
            float rgb[3];
            if (!sample_map(map, d, rgb)) continue;
            for (int c = 0; c < 3; ++c) acc[c] += rgb[c];
          }
        float* o = &im.rgb[3 * (size_t(y) * im.width + x)];
        for (int c = 0; c < 3; ++c) o[c] = float(acc[c] / (k * k));
      }
  });
  return im;
}

}  // namespace lp
