#include "calib/lens_model.h"

#include <cstdio>

#include "core/error.h"

// mrcal.h is a C header without extern "C".
extern "C" {
#include <mrcal/mrcal.h>
}

namespace lp {
namespace {

using S = OpenCVSolver;
using F = LensFamily;

// One row per LensType, in enum order (lens_type_info indexes it). mrcal's rows repeat what
// MRCAL_LENSMODEL_LIST and mrcal_lensmodel_metadata say (tests/calib/lens_model_test.cpp
// checks them against mrcal); configured models ask mrcal for their parameter count.
const std::vector<LensTypeInfo> kTable = {
    // type, name, params, configured, mrcal, beyond 90, central, OpenCV solver, distortion_model,
    // coefficients, zero padded, family, candidate
    {LensType::Pinhole, "LENSMODEL_PINHOLE", 4, false, true, false, true, S::CalibrateCamera, "plumb_bob", 4, true,
     F::Perspective, "LENSMODEL_PINHOLE"},
    {LensType::Stereographic, "LENSMODEL_STEREOGRAPHIC", 4, false, true, true, true, S::None, nullptr, 0, false,
     F::Stereographic, "LENSMODEL_STEREOGRAPHIC"},
    {LensType::LonLat, "LENSMODEL_LONLAT", 4, false, true, true, true, S::None, nullptr, 0, false, F::Panoramic,
     nullptr},
    {LensType::LatLon, "LENSMODEL_LATLON", 4, false, true, true, true, S::None, nullptr, 0, false, F::Panoramic,
     nullptr},
    {LensType::OpenCV4, "LENSMODEL_OPENCV4", 8, false, true, false, true, S::CalibrateCamera, "plumb_bob", 4, false,
     F::Perspective, nullptr},
    // OpenCV's default 5-coefficient model is the "plumb_bob" candidate.
    {LensType::OpenCV5, "LENSMODEL_OPENCV5", 9, false, true, false, true, S::CalibrateCamera, "plumb_bob", 5, false,
     F::Perspective, "plumb_bob"},
    {LensType::OpenCV8, "LENSMODEL_OPENCV8", 12, false, true, false, true, S::CalibrateCamera, "rational", 8, false,
     F::Perspective, "LENSMODEL_OPENCV8"},
    // OpenCV's thin-prism model: calibrateCamera solves it, but the YAML writer has no
    // distortion_model name for it (none of CONVENTIONS.md's four).
    {LensType::OpenCV12, "LENSMODEL_OPENCV12", 16, false, true, false, true, S::CalibrateCamera, nullptr, 0, false,
     F::Perspective, nullptr},
    {LensType::Cahvor, "LENSMODEL_CAHVOR", 9, false, true, false, true, S::None, nullptr, 0, false, F::Perspective,
     nullptr},
    {LensType::Cahvore, "LENSMODEL_CAHVORE", -1, true, true, false, false, S::None, nullptr, 0, false, F::Perspective,
     nullptr},
    {LensType::SplinedStereographic, "LENSMODEL_SPLINED_STEREOGRAPHIC", -1, true, true, true, true, S::None, nullptr,
     0, false, F::Stereographic, "LENSMODEL_SPLINED_STEREOGRAPHIC"},
    {LensType::KannalaBrandt, "LENSMODEL_KANNALA_BRANDT", 8, false, false, true, true, S::Fisheye, "fisheye", 4,
     false, F::Fisheye, "LENSMODEL_KANNALA_BRANDT"},
    // xi beyond 1 images the whole sphere but the back hemisphere's rim.
    {LensType::OmnidirMei, "LENSMODEL_OMNIDIR_MEI", 9, false, false, true, true, S::Omnidir, "omnidir", 4, false,
     F::Catadioptric, "LENSMODEL_OMNIDIR_MEI"},
};

std::string known_names() {
  std::string s;
  for (const LensTypeInfo& t : kTable) s += (s.empty() ? "" : ", ") + std::string(t.name) + (t.configured ? "_..." : "");
  return s;
}

}  // namespace

const std::vector<LensTypeInfo>& lens_types() { return kTable; }

const LensTypeInfo& lens_type_info(LensType type) { return kTable.at(size_t(type)); }

std::string lens_type_name(LensType type) { return lens_type_info(type).name; }

LensModel::LensModel(LensType type) : type_(type), name_(lens_type_info(type).name), params_(lens_type_info(type).params) {
  if (lens_type_info(type).configured)
    throw InputError("lens model " + name_ + " needs a configuration (e.g. " + name_ + "_order=3_...)");
}

std::optional<LensModel> LensModel::try_parse(const std::string& name) {
  for (const LensTypeInfo& t : kTable) {
    if (!t.configured) {
      if (name == t.name) return LensModel(t.type, name, t.params);
      continue;
    }
    // Configured: mrcal parses (and validates) the configuration.
    const std::string prefix = std::string(t.name) + "_";
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    mrcal_lensmodel_t m;
    if (!mrcal_lensmodel_from_name(&m, name.c_str()) || !mrcal_lensmodel_type_is_valid(m.type)) return std::nullopt;
    return LensModel(t.type, name, mrcal_lensmodel_num_params(&m));
  }
  return std::nullopt;
}

LensModel LensModel::parse(const std::string& name) {
  if (auto m = try_parse(name)) return *m;
  for (const LensTypeInfo& t : kTable)
    if (t.configured && name.compare(0, std::string(t.name).size(), t.name) == 0)
      throw InputError("lens model '" + name + "': mrcal rejects its configuration");
  throw InputError("unknown lens model '" + name + "' (known: " + known_names() + ")");
}

std::string splined_stereographic_name(int order, int nx, int ny, int fov_x_deg) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%s_order=%d_Nx=%d_Ny=%d_fov_x_deg=%d",
                lens_type_info(LensType::SplinedStereographic).name, order, nx, ny, fov_x_deg);
  return buf;
}

LensModel LensModel::splined_stereographic(int order, int nx, int ny, int fov_x_deg) {
  return parse(splined_stereographic_name(order, nx, ny, fov_x_deg));
}

std::optional<LensType> lens_type_from_opencv(const std::string& distortion_model, int coefficients) {
  for (const LensTypeInfo& t : kTable)
    if (t.opencv_distortion_model && !t.opencv_zero_padded && distortion_model == t.opencv_distortion_model &&
        coefficients == t.opencv_coefficients)
      return t.type;
  return std::nullopt;
}

std::string opencv_distortion_model_names() {
  std::string s;
  for (const LensTypeInfo& t : kTable)
    if (t.opencv_distortion_model && s.find(t.opencv_distortion_model) == std::string::npos)
      s += (s.empty() ? "" : ", ") + std::string(t.opencv_distortion_model);
  return s;
}

LensType candidate_lens_type(const std::string& candidate) {
  for (const LensTypeInfo& t : kTable)
    if (t.candidate && candidate == t.candidate) return t.type;
  std::string known;
  for (const std::string& c : all_candidate_names()) known += (known.empty() ? "" : ", ") + c;
  throw InputError("unknown model '" + candidate + "' (candidates: " + known + ")");
}

std::string candidate_name(LensType type) {
  const LensTypeInfo& t = lens_type_info(type);
  if (!t.candidate) throw InputError(std::string(t.name) + " is not a calibration candidate");
  return t.candidate;
}

const std::vector<std::string>& all_candidate_names() {
  // Cheapest first, as the table that calibrate() prints.
  static const std::vector<std::string> names = [] {
    std::vector<std::string> n;
    for (LensType t : {LensType::Pinhole, LensType::Stereographic, LensType::OpenCV5, LensType::KannalaBrandt,
                       LensType::OpenCV8, LensType::SplinedStereographic, LensType::OmnidirMei})
      n.push_back(candidate_name(t));
    return n;
  }();
  return names;
}

bool is_perspective(LensType type) { return lens_type_info(type).family == LensFamily::Perspective; }

}  // namespace lp
