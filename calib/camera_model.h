// A calibrated camera: lens model + intrinsics + image size, with project/unproject for
// every model, including rays beyond 90 deg from the axis for > 180 deg fisheyes.
//
// Models (calib/lens_model.h has the table: names, parameter counts, what each can do; mrcal's
// other models, LONLAT, LATLON, OPENCV4/12, CAHVOR(E), also project through mrcal):
//   LENSMODEL_PINHOLE                      fx fy cx cy
//   LENSMODEL_STEREOGRAPHIC                fx fy cx cy
//   LENSMODEL_OPENCV8                      fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6 (OpenCV rational)
//   LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=..._Ny=..._fov_x_deg=...   fx fy cx cy + spline
//   LENSMODEL_KANNALA_BRANDT               fx fy cx cy k1 k2 k3 k4 (cv::fisheye; not an mrcal model)
//   LENSMODEL_OMNIDIR_MEI                  fx fy cx cy xi k1 k2 p1 p2 (cv::omnidir; not an mrcal model)
// Coordinates: pixels with OpenCV's convention (pixel centres at integers, x right, y
// down); camera frame x right, y down, z forward (both OpenCV and mrcal). A model's
// `world_from_camera` is not part of it: the probe stage adds the rotation.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/vec3.h"

namespace cv {
class FileNode;
class Mat;
class FileStorage;
}  // namespace cv

namespace lp {

struct CameraModel {
  std::string lensmodel;           // full name (LensModel::parse), e.g. LENSMODEL_OPENCV8
  std::vector<double> intrinsics;  // as listed above for the model
  int width = 0, height = 0;       // image size the model was calibrated for
  // Informational: where it came from and how well it fits (written to the files' comments).
  double rms_reprojection_px = 0;
  double cross_validation_px = 0;  // headline accuracy: see calib/geometric.h
};

// Shorthands for LensModel::parse(lensmodel).param_count() (InputError for an unknown name)
// and .is_mrcal() (false for an unknown name).
int intrinsics_count(const std::string& lensmodel);
bool is_mrcal_model(const std::string& lensmodel);

// Pixel of a camera-frame direction (need not be normalised); nullopt where the model
// cannot image it (behind a pinhole, beyond a fisheye's domain).
struct Pixel {
  double x = 0, y = 0;
};
std::optional<Pixel> project(const CameraModel& model, Vec3 direction_camera);
// Unit camera-frame direction of a pixel; nullopt where the model has no ray.
std::optional<Vec3> unproject(const CameraModel& model, Pixel pixel);
namespace detail {
// unproject's own path for plumb_bob (OpenCV4/5: `intrinsics` fx fy cx cy and `ndist` 4 or 5
// coefficients), exposed for its test: nullopt where unproject falls back to mrcal's.
std::optional<Vec3> opencv_unproject(const double* intrinsics, int ndist, Pixel pixel);
// unproject's path for Kannala-Brandt (fx fy cx cy k1-k4), with the Newton iterations it
// took, for the test that keeps its root finder from bisecting back to roots it has found.
std::optional<Vec3> kb_unproject(const double* intrinsics, Pixel pixel, int* iterations = nullptr);
}  // namespace detail

// Files. .cameramodel is mrcal's text format (readable by mrcal's Python and C readers);
// only mrcal models can be written to it (InputError otherwise). OpenCV FileStorage YAML
// with the keys of CONVENTIONS.md "Camera models" (image_width, image_height,
// camera_matrix, distortion_coefficients, distortion_model = rational | plumb_bob |
// fisheye | omnidir (+ xi)); models OpenCV has no form for (stereographic, splined) are
// refused with InputError. Both written atomically.
// optimization_inputs: mrcal's serialised solve (calib/mrcal_optimization_inputs.h), written
// as mrcal's Python writes it ('icam_intrinsics': 0 and 'optimization_inputs': b'...');
// empty: none. The reader ignores it.
void write_cameramodel(const std::string& path, const CameraModel& model, const std::string& optimization_inputs = "");
CameraModel read_cameramodel(const std::string& path);
void write_opencv_yaml(const std::string& path, const CameraModel& model);
CameraModel read_opencv_yaml(const std::string& path);
// The OpenCV FileStorage file at `path` (YAML, or XML for a .xml path), read through
// read_text_file and opened; InputError naming the file if it is not one. The text is first
// held to the subsets of calib/opencv_storage_check.h: OpenCV 4.6's parsers abort, crash or
// loop forever on some text outside them (found by fuzz_opencv_yaml and fuzz_opencv_xml).
cv::FileStorage open_opencv_storage(const std::string& path);
// An OpenCV FileStorage matrix of at most max_values values into *out; InputError naming
// `path` and `key` otherwise. The size is checked before OpenCV allocates rows x cols from
// the header (a 48 GB allocation from a 300-byte file, found by fuzz_opencv_yaml).
void read_yaml_matrix(const cv::FileNode& node, const std::string& path, const char* key, int max_values, cv::Mat* out);
// By extension: .cameramodel or .yaml/.yml/.xml.
CameraModel read_camera_model(const std::string& path);

}  // namespace lp
