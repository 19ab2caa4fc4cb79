// The lens-model table (calib/lens_model.h) against mrcal's own table and the file formats.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <unistd.h>

#include "calib/camera_model.h"
#include "calib/lens_model.h"
#include "calib/mrcal_solve.h"
#include "core/error.h"

// mrcal.h is a C header without extern "C".
extern "C" {
#include <mrcal/mrcal.h>
}

namespace lp {
namespace {

namespace fs = std::filesystem;

// One full (configured where needed) name per table row.
std::string example_name(const LensTypeInfo& t) {
  if (t.type == LensType::SplinedStereographic) return splined_stereographic_name(3, 8, 6, 200);
  if (t.type == LensType::Cahvore) return std::string(t.name) + "_linearity=0.30";
  return t.name;
}

// A model of the row's type with plausible intrinsics (core, small distortion, Mei's xi).
CameraModel example_model(const LensTypeInfo& t) {
  const LensModel lens = LensModel::parse(example_name(t));
  CameraModel m{lens.name(), std::vector<double>(size_t(lens.param_count()), 0.0), 640, 480};
  m.intrinsics[0] = 400.25;
  m.intrinsics[1] = 401.5;
  m.intrinsics[2] = 319.75;
  m.intrinsics[3] = 240.125;
  if (lens.is_mei()) m.intrinsics[4] = 0.75;
  for (size_t i = lens.is_mei() ? 5 : 4; i < m.intrinsics.size(); ++i) m.intrinsics[i] = 0.001 * double(i);
  return m;
}

std::string temp_path(const std::string& name) {
  // The pid: other checkouts may run the same tests at the same time.
  const fs::path dir = fs::temp_directory_path() / ("lightprobe_lens_model_test_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return (dir / name).string();
}

TEST(LensModel, TableHasOneRowPerTypeInEnumOrder) {
  const auto& table = lens_types();
  ASSERT_EQ(table.size(), size_t(LensType::OmnidirMei) + 1);
  std::set<std::string> names;
  for (size_t i = 0; i < table.size(); ++i) {
    EXPECT_EQ(size_t(table[i].type), i);
    EXPECT_TRUE(names.insert(table[i].name).second) << table[i].name;
    EXPECT_EQ(lens_type_name(table[i].type), table[i].name);
  }
}

TEST(LensModel, EveryModelRoundTripsItsName) {
  for (const LensTypeInfo& t : lens_types()) {
    const std::string name = example_name(t);
    const LensModel m = LensModel::parse(name);
    EXPECT_EQ(m.type(), t.type) << name;
    EXPECT_EQ(m.name(), name);
    EXPECT_EQ(LensModel::parse(m.name()), m);
    if (!t.configured) {
      EXPECT_EQ(LensModel(t.type).name(), name);
    }
  }
}

TEST(LensModel, MrcalModelsMatchMrcalsOwnTable) {
  int mrcal_rows = 0;
  for (const LensTypeInfo& t : lens_types()) {
    const std::string name = example_name(t);
    mrcal_lensmodel_t m;
    const bool known = mrcal_lensmodel_from_name(&m, name.c_str()) && mrcal_lensmodel_type_is_valid(m.type);
    EXPECT_EQ(known, t.mrcal) << name;
    if (!known) continue;
    ++mrcal_rows;
    // Parameter count, both through mrcal's C API directly and through our wrapper of it.
    EXPECT_EQ(LensModel::parse(name).param_count(), mrcal_lensmodel_num_params(&m)) << name;
    EXPECT_EQ(LensModel::parse(name).param_count(), mrcal_model_param_count(name)) << name;
    if (!t.configured) {
      EXPECT_EQ(t.params, mrcal_lensmodel_num_params(&m)) << name;
    }
    // mrcal names the type as we do (configured: its unconfigured form starts with our prefix).
    const std::string unconfigured = mrcal_lensmodel_name_unconfigured(&m);
    EXPECT_EQ(unconfigured.rfind(t.name, 0), 0u) << unconfigured;
    // "Beyond 90 deg" is mrcal's can_project_behind_camera.
    EXPECT_EQ(t.beyond_90_deg, bool(mrcal_lensmodel_metadata(&m).can_project_behind_camera)) << name;
  }
  // Every model mrcal supports is in the table.
  int supported = 0;
  for (const char* const* n = mrcal_supported_lensmodel_names(); *n; ++n) ++supported;
  EXPECT_EQ(mrcal_rows, supported);
}

TEST(LensModel, BeyondNinetyDegreesMeansARayAt100DegreesProjects) {
  // An independent check of the flag for every model: project() of a ray 100 deg off the axis.
  for (const LensTypeInfo& t : lens_types()) {
    if (t.type == LensType::Cahvore || t.type == LensType::Cahvor) continue;  // mrcal has no such ray either
    const CameraModel m = example_model(t);
    const double a = 100 * M_PI / 180;
    const bool images = project(m, {std::sin(a), 0, std::cos(a)}).has_value();
    EXPECT_EQ(images, t.beyond_90_deg) << t.name;
  }
}

TEST(LensModel, EveryModelWithAnOpenCVFormRoundTripsThroughYaml) {
  for (const LensTypeInfo& t : lens_types()) {
    const CameraModel m = example_model(t);
    const std::string path = temp_path(std::string("rt_") + t.name + ".yaml");
    if (!t.opencv_distortion_model) {
      EXPECT_THROW(write_opencv_yaml(path, m), InputError) << t.name;
      continue;
    }
    write_opencv_yaml(path, m);
    cv::FileStorage f(path, cv::FileStorage::READ);
    EXPECT_EQ(std::string(f["distortion_model"]), t.opencv_distortion_model) << t.name;
    cv::Mat D;
    f["distortion_coefficients"] >> D;
    EXPECT_EQ(int(D.total()), t.opencv_coefficients) << t.name;
    // The distortion_model and coefficient count name the model again (pinhole: through the
    // lensmodel key our writer adds).
    if (!t.opencv_zero_padded) {
      EXPECT_EQ(lens_type_from_opencv(t.opencv_distortion_model, t.opencv_coefficients), t.type);
    }
    const CameraModel back = read_opencv_yaml(path);
    EXPECT_EQ(back.lensmodel, m.lensmodel);
    EXPECT_EQ(back.intrinsics, m.intrinsics) << t.name;
  }
}

TEST(LensModel, EveryMrcalModelRoundTripsThroughCameramodel) {
  for (const LensTypeInfo& t : lens_types()) {
    const CameraModel m = example_model(t);
    const std::string path = temp_path(std::string("rt_") + t.name + ".cameramodel");
    if (!t.mrcal) {
      EXPECT_THROW(write_cameramodel(path, m), InputError) << t.name;
      continue;
    }
    write_cameramodel(path, m);
    const CameraModel back = read_cameramodel(path);
    EXPECT_EQ(back.lensmodel, m.lensmodel) << t.name;
    EXPECT_EQ(back.intrinsics, m.intrinsics) << t.name;
  }
}

TEST(LensModel, CapabilitiesTheCodeAsksFor) {
  EXPECT_TRUE(LensModel(LensType::KannalaBrandt).fits_cv_fisheye());
  EXPECT_FALSE(LensModel(LensType::KannalaBrandt).is_mrcal());
  EXPECT_TRUE(LensModel(LensType::OmnidirMei).is_mei());
  EXPECT_EQ(LensModel(LensType::OmnidirMei).info().opencv, OpenCVSolver::Omnidir);
  EXPECT_TRUE(LensModel::parse(splined_stereographic_name(3, 16, 12, 120)).is_splined());
  EXPECT_EQ(LensModel::splined_stereographic(3, 16, 12, 120).param_count(), 4 + 2 * 16 * 12);
  EXPECT_FALSE(LensModel(LensType::OpenCV12).has_opencv_form());
  EXPECT_FALSE(lens_type_info(LensType::Cahvore).central);
  for (LensType t : {LensType::Pinhole, LensType::OpenCV5, LensType::OpenCV8})
    EXPECT_EQ(lens_type_info(t).opencv, OpenCVSolver::CalibrateCamera);
  // Without a distortion_model, only the counts one form has name a model.
  EXPECT_EQ(lens_type_from_opencv("plumb_bob", 5), LensType::OpenCV5);
  EXPECT_EQ(lens_type_from_opencv("plumb_bob", 4), LensType::OpenCV4);
  EXPECT_EQ(lens_type_from_opencv("fisheye", 4), LensType::KannalaBrandt);
  EXPECT_EQ(lens_type_from_opencv("omnidir", 4), LensType::OmnidirMei);
  EXPECT_FALSE(lens_type_from_opencv("fisheye", 5).has_value());
  EXPECT_FALSE(lens_type_from_opencv("thin_prism", 12).has_value());
}

TEST(LensModel, CandidatesNameTheirTypesBothWays) {
  ASSERT_EQ(all_candidate_names().size(), 7u);
  for (const std::string& c : all_candidate_names()) EXPECT_EQ(candidate_name(candidate_lens_type(c)), c);
  EXPECT_EQ(candidate_lens_type("plumb_bob"), LensType::OpenCV5);
  EXPECT_EQ(all_candidate_names().front(), lens_type_name(LensType::Pinhole));  // cheapest first
  EXPECT_THROW(candidate_name(LensType::LonLat), InputError);
}

// The message of the InputError `f` throws (one line), or "" with a failure.
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.find('\n'), std::string::npos) << what;
    return what;
  }
  ADD_FAILURE() << "no InputError";
  return "";
}

TEST(LensModel, UnknownNamesAreRefusedInOneLine) {
  for (const std::string bad : {"", "LENSMODEL_NONSENSE", "lensmodel_pinhole", "LENSMODEL_PINHOLE_", "fisheye",
                                "LENSMODEL_OPENCV8 "}) {
    EXPECT_FALSE(LensModel::try_parse(bad).has_value()) << bad;
    const std::string what = error_of([&] { LensModel::parse(bad); });
    EXPECT_NE(what.find("'" + bad + "'"), std::string::npos) << what;
    std::printf("  %s\n", what.c_str());
  }
  // A configured model with a configuration mrcal refuses, or none.
  EXPECT_NE(error_of([] { LensModel::parse("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=8"); }).find("configuration"),
            std::string::npos);
  EXPECT_THROW(LensModel{LensType::SplinedStereographic}, InputError);  // braces: clang parses (..) as a declaration
  EXPECT_THROW(candidate_lens_type("LENSMODEL_OPENCV5"), InputError);  // a model, but not a candidate name
  EXPECT_THROW(candidate_lens_type("rational"), InputError);
}

}  // namespace
}  // namespace lp
