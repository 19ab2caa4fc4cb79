// Every lens model lightprobe knows, in one table (after mrcal's mrcal_lensmodel_type_t and
// mrcal_lensmodel_metadata): its canonical name, parameter count, what it can do, and the
// name each file format gives it. Code asks a model what it can do, never which string it is.
//
// Names are mrcal's where mrcal has the model (LENSMODEL_OPENCV8, ...); the two that mrcal
// lacks follow its spelling (LENSMODEL_KANNALA_BRANDT: cv::fisheye; LENSMODEL_OMNIDIR_MEI:
// cv::omnidir). Configured models carry their configuration in the name, as mrcal's
// (LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8_Ny=6_fov_x_deg=200), and their parameter
// count follows from it; the bare prefix is the type's name. CameraModel::lensmodel holds the
// full name; LensModel::parse turns it into a model and fails with a one-line InputError on a
// name it does not know.
//
// File formats (CONVENTIONS.md "Camera models"): .cameramodel's `lensmodel` is the full name
// (mrcal models only); OpenCV FileStorage YAML's `distortion_model` is plumb_bob (pinhole as
// four zero coefficients, OpenCV4, OpenCV5), rational (OpenCV8), fisheye (Kannala-Brandt) or
// omnidir (Mei, with xi); the other models have no OpenCV form.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace lp {

enum class LensType {
  Pinhole,
  Stereographic,
  LonLat,
  LatLon,
  OpenCV4,
  OpenCV5,
  OpenCV8,
  OpenCV12,
  Cahvor,
  Cahvore,
  SplinedStereographic,
  KannalaBrandt,
  OmnidirMei,
};

// How a lens maps angle to image radius, as far as choosing among models goes: the outlier
// reference of a calibration is the best-fitting family's representative (geometric.h).
enum class LensFamily {
  Perspective,    // pinhole-based: pinhole, OpenCV's radial-tangential models, CAHVOR(E)
  Stereographic,  // stereographic and its splined refinement (mrcal's wide-lens models)
  Panoramic,      // longitude/latitude projections (mrcal's LONLAT, LATLON)
  Fisheye,        // Kannala-Brandt: polynomial in the angle, > 180 deg lenses
  Catadioptric,   // Mei's unified model: mirror cameras
};

// Which OpenCV calibrator solves the model (and therefore which OpenCV functions read it).
enum class OpenCVSolver {
  None,
  CalibrateCamera,  // cv::calibrateCamera, cv::projectPoints
  Fisheye,          // cv::fisheye
  Omnidir,          // cv::omnidir (contrib ccalib)
};

// One row of the table.
struct LensTypeInfo {
  LensType type;
  const char* name;   // canonical; configured models: the prefix before their configuration
  int params;         // intrinsics (fx fy cx cy first); -1: from the configuration
  bool configured;    // the full name carries a configuration (_key=value...)
  bool mrcal;         // mrcal has it: .cameramodel holds it, mrcal projects and solves it
  bool beyond_90_deg; // can image rays more than 90 deg from the optical axis
  bool central;       // every ray passes through one point (mrcal: CAHVORE is not central)
  OpenCVSolver opencv;
  const char* opencv_distortion_model;  // FileStorage distortion_model; nullptr: no OpenCV form
  int opencv_coefficients;              // entries of distortion_coefficients in that form
  bool opencv_zero_padded;              // those entries are zeros the model lacks (pinhole)
  LensFamily family;
  const char* candidate;  // its name among calibrate()'s candidates; nullptr: not a candidate
};

// The whole table, one row per LensType, in enum order.
const std::vector<LensTypeInfo>& lens_types();
const LensTypeInfo& lens_type_info(LensType type);

// A perspective model (pinhole, plumb_bob, rational) divides by the ray's depth: it cannot
// image a ray at or beyond 90 deg off its axis. Where a wide-angle fit of some views fits them
// and sees a corner beyond kPerspectiveFieldLimitDeg, a perspective fit of those views can only
// fold the boards into the half-space ahead of the camera: on the shared catadioptric sets,
// seen to 104-120 deg, such fits missed the corners by 2.1-12.6 px, and mrcal's rational model
// ran to its 300 iterations to get there (0.1-0.4 s of CPU a fit). The 10 deg over 90 leave
// room for the wide fit's own error in the field. The selection and the outlier stage's
// reference choice do not fit perspective models there (CandidateOptions, OutlierOptions,
// with calibration_solve.h's wide_fit_field).
constexpr double kPerspectiveFieldLimitDeg = 100;
bool is_perspective(LensType type);
// Canonical name of a type (configured types: the prefix).
std::string lens_type_name(LensType type);

// A lens model with its configuration: what a CameraModel's `lensmodel` names.
class LensModel {
 public:
  // Unconfigured types only (InputError for a configured one: use parse or splined()).
  explicit LensModel(LensType type);
  // The full name (configured: with a configuration mrcal accepts). InputError naming the
  // name and the known ones when unknown or badly configured.
  static LensModel parse(const std::string& name);
  static std::optional<LensModel> try_parse(const std::string& name);
  // mrcal's splined stereographic model: cubic (order 3) or quadratic, nx x ny control
  // points over fov_x_deg horizontally. InputError when mrcal rejects the configuration.
  static LensModel splined_stereographic(int order, int nx, int ny, int fov_x_deg);

  LensType type() const { return type_; }
  const LensTypeInfo& info() const { return lens_type_info(type_); }
  const std::string& name() const { return name_; }  // full name, as files write it
  int param_count() const { return params_; }
  bool is_mrcal() const { return info().mrcal; }
  bool beyond_90_deg() const { return info().beyond_90_deg; }
  bool has_opencv_form() const { return info().opencv_distortion_model != nullptr; }
  bool is_mei() const { return type_ == LensType::OmnidirMei; }
  bool fits_cv_fisheye() const { return info().opencv == OpenCVSolver::Fisheye; }
  bool is_splined() const { return type_ == LensType::SplinedStereographic; }
  bool operator==(const LensModel& o) const { return name_ == o.name_; }

 private:
  LensModel(LensType type, std::string name, int params) : type_(type), name_(std::move(name)), params_(params) {}
  LensType type_;
  std::string name_;
  int params_;
};

// mrcal's configured name of a splined stereographic model (not validated; see
// LensModel::splined_stereographic).
std::string splined_stereographic_name(int order, int nx, int ny, int fov_x_deg);

// The model an OpenCV FileStorage file describes by its distortion_model and number of
// distortion_coefficients (pinhole's zero-padded form is never the answer: its file also
// records lensmodel, see camera_model.cpp); nullopt when no row matches.
std::optional<LensType> lens_type_from_opencv(const std::string& distortion_model, int coefficients);
// The distortion_model values the table knows, for error messages ("rational, plumb_bob, ...").
std::string opencv_distortion_model_names();

// calibrate()'s candidates (geometric.h CalibrateOptions::candidates): each names a type
// (the splined one is configured from the options). InputError on an unknown candidate.
LensType candidate_lens_type(const std::string& candidate);
std::string candidate_name(LensType type);  // InputError for a type that is not a candidate
// Every candidate, in the order calibrate() fits and lists them.
const std::vector<std::string>& all_candidate_names();

}  // namespace lp
