// Luminance and lux from exposure metadata against the synthetic camera's truth, and the
// errors bad metadata must give.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <vector>

#include "core/accuracy.h"
#include "core/error.h"
#include "estimate/exposure_metering.h"
#include "estimate/walkthrough.h"
#include "estimate/white_balance_cct.h"

namespace lp {
namespace {

// The metadata an auto exposure reaching `ae_target` exactly would report for a scene of
// mean luminance L (cd m^-2) through photometric scale k: t g = Y_target k / L.
FrameMetadata metadata_for(double L, const MeteringOptions& cam, double t_max = 1.0 / 30) {
  const double product = cam.ae_target * cam.photometric_scale.value() / L;
  FrameMetadata m;
  m.exposure_s = std::min(product, t_max);
  m.gain_db = 20 * std::log10(product / m.exposure_s);
  return m;
}

std::string message_of(const FrameMetadata& m, const MeteringOptions& cam) {
  try {
    meter_frame(m, cam, "track.jsonl:7");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(ExposureMetering, CalibrationAndMeterRoutesRecoverLuminance) {
  MeteringOptions cam = walkthrough_camera();
  MeteringOptions meter = cam;
  meter.photometric_scale.reset();
  for (double L : {0.5, 5.0, 50.0, 500.0, 5000.0, 50000.0}) {
    const FrameMetadata m = metadata_for(L, cam);
    const LightReading a = meter_frame(m, cam, "t");
    const LightReading b = meter_frame(m, meter, "t");
    EXPECT_NEAR(a.luminance / L, 1.0, 1e-9) << L;
    EXPECT_NEAR(b.luminance / L, 1.0, 1e-9) << L;  // k = K N^2 / (S_base Y_target)
    EXPECT_EQ(a.route, "calibration");
    EXPECT_EQ(b.route, "meter");
  }
}

// Lux: in a uniform field of luminance L the illuminance on any plane is pi L, which is
// what the estimate assumes; checked against the map integral of a uniform map.
TEST(ExposureMetering, IlluminanceOfAUniformFieldIsPiL) {
  const MeteringOptions cam = walkthrough_camera();
  const double L = 120.0;  // cd m^-2
  EnvMap uniform = make_latlong(64, 32);
  for (float& v : uniform.rgb) v = float(L);
  const double truth = map_irradiance(uniform, {0.3, 0.4, 0.866});  // lux (L in cd m^-2)
  const LightReading r = meter_frame(metadata_for(L, cam), cam, "t");
  EXPECT_NEAR(r.illuminance / truth, 1.0, 0.002);
}

// Stated tolerance: with the frame's metered mean recorded, the luminance of every frame of
// the walk-through equals the true mean luminance the camera saw to 1e-6 (exact inverse);
// without it (AE assumed on target) to the 0.1 dB gain step, +-0.6 %, where the AE is not
// at a limit.
TEST(ExposureMetering, WalkthroughFramesRecoverTrueLuminance) {
  const Room room = default_room();
  WalkthroughOptions o;
  o.rays_x = 8;
  const auto path = walkthrough_path(room, o);
  ASSERT_GT(path.size(), 100u);
  int checked = 0;
  for (size_t i = 0; i < path.size(); i += 7) {
    const CameraRender r = render_camera_frame(room, path[i].position, path[i].view, o);
    const LightReading with_code = meter_frame(r.metadata, o.camera, "t");
    EXPECT_NEAR(with_code.luminance / r.true_luminance, 1.0, 1e-6) << i;
    FrameMetadata no_code = r.metadata;
    no_code.mean_code.reset();
    // At the AE's limits (shortest exposure, highest gain) the target is missed: skip.
    if (r.metadata.exposure_s <= o.t_min || *r.metadata.gain_db >= 20 * std::log10(o.gain_max) - 0.05) continue;
    const LightReading assumed = meter_frame(no_code, o.camera, "t");
    EXPECT_NEAR(assumed.luminance / r.true_luminance, 1.0, 0.006) << i;
    ++checked;
  }
  EXPECT_GT(checked, 10);
}

TEST(ExposureMetering, ApertureScalesAsFNumberSquared) {
  MeteringOptions cam = walkthrough_camera();
  cam.calibration_f_number = 2.0;
  FrameMetadata m = metadata_for(100, cam);
  m.f_number = 4.0;
  EXPECT_NEAR(meter_frame(m, cam, "t").luminance, 400.0, 1e-9);
  MeteringOptions meter = cam;
  meter.photometric_scale.reset();
  EXPECT_NEAR(meter_frame(m, meter, "t").luminance, 400.0, 1e-9);
}

TEST(ExposureMetering, GainFromDbLinearOrIso) {
  const MeteringOptions cam = walkthrough_camera();
  FrameMetadata a;
  a.exposure_s = 0.01;
  a.gain_db = 6.0206;
  FrameMetadata b;
  b.exposure_s = 0.01;
  b.analog_gain = 1.6;
  b.digital_gain = 1.25;
  FrameMetadata c;
  c.exposure_s = 0.01;
  c.iso = 200;
  const double la = meter_frame(a, cam, "t").luminance;
  EXPECT_NEAR(meter_frame(b, cam, "t").luminance / la, 1.0, 1e-4);
  EXPECT_NEAR(meter_frame(c, cam, "t").luminance / la, 1.0, 1e-4);
}

TEST(ExposureMetering, ColourFromBrightPixelsWbGainsOrCct) {
  const MeteringOptions cam = walkthrough_camera();
  FrameMetadata m = metadata_for(100, cam);
  m.wb_gains = wb_gains_for_illuminant(planckian_rgb(3200));
  LightReading r = meter_frame(m, cam, "t");
  EXPECT_EQ(r.colour_from, "wb_gains");
  EXPECT_NEAR(r.cct_k, 3200, 0.005 * 3200);
  EXPECT_NEAR(0.2126 * r.colour[0] + 0.7152 * r.colour[1] + 0.0722 * r.colour[2], 1.0, 1e-12);
  EXPECT_NEAR(r.radiance()[1] * 683 / r.colour[1], 100, 1e-9);
  // A green light no black body explains: the brightest pixels keep its colour.
  m.bright_rgb = std::array<double, 3>{0.1, 0.9, 0.1};
  r = meter_frame(m, cam, "t");
  EXPECT_EQ(r.colour_from, "bright_rgb");
  EXPECT_GT(r.colour[1], 3 * r.colour[0]);
  EXPECT_GT(r.duv, 0.02);
  FrameMetadata only_cct = metadata_for(100, cam);
  only_cct.cct_k = 5000;
  r = meter_frame(only_cct, cam, "t");
  EXPECT_EQ(r.colour_from, "cct");
  EXPECT_EQ(r.cct_k, 5000);
  EXPECT_GT(r.colour[2], 0.7);  // 5000 K: a little warmer than D65
  EXPECT_LT(r.colour[2], r.colour[0]);
}

// A sensor whose raw RGB is not Rec. 709: its WB gains give the right CCT only through its
// colour matrix.
TEST(ExposureMetering, ColourMatrixMapsSensorRgbToRec709) {
  const std::array<double, 9> m{1.6, -0.5, -0.1, -0.2, 1.5, -0.3, 0.0, -0.5, 1.5};  // camera -> Rec. 709
  // Inverse by cofactors: Rec. 709 -> camera.
  const double det = m[0] * (m[4] * m[8] - m[5] * m[7]) - m[1] * (m[3] * m[8] - m[5] * m[6]) + m[2] * (m[3] * m[7] - m[4] * m[6]);
  const std::array<double, 9> inv{(m[4] * m[8] - m[5] * m[7]) / det, (m[2] * m[7] - m[1] * m[8]) / det, (m[1] * m[5] - m[2] * m[4]) / det,
                                  (m[5] * m[6] - m[3] * m[8]) / det, (m[0] * m[8] - m[2] * m[6]) / det, (m[2] * m[3] - m[0] * m[5]) / det,
                                  (m[3] * m[7] - m[4] * m[6]) / det, (m[1] * m[6] - m[0] * m[7]) / det, (m[0] * m[4] - m[1] * m[3]) / det};
  MeteringOptions cam = walkthrough_camera();
  for (double t : {2700.0, 4000.0, 6500.0}) {
    const auto rec = planckian_rgb(t);
    const std::array<double, 3> raw{inv[0] * rec[0] + inv[1] * rec[1] + inv[2] * rec[2],
                                    inv[3] * rec[0] + inv[4] * rec[1] + inv[5] * rec[2],
                                    inv[6] * rec[0] + inv[7] * rec[1] + inv[8] * rec[2]};
    FrameMetadata f = metadata_for(100, cam);
    f.wb_gains = wb_gains_for_illuminant(raw);
    cam.colour_matrix.reset();
    const double without = meter_frame(f, cam, "t").cct_k;
    cam.colour_matrix = m;
    EXPECT_NEAR(meter_frame(f, cam, "t").cct_k, t, 0.005 * t);
    // The matrix keeps white (rows sum to 1), so it matters away from D65 only.
    if (t < 5000) {
      EXPECT_GT(std::fabs(without - t), 0.05 * t) << t;
    }
  }
}

TEST(ExposureMetering, BadMetadataNamesTheFrameAndTheField) {
  const MeteringOptions cam = walkthrough_camera();
  FrameMetadata m = metadata_for(100, cam);
  FrameMetadata zero = m;
  zero.exposure_s = 0;
  EXPECT_NE(message_of(zero, cam).find("track.jsonl:7: exposure_s"), std::string::npos) << message_of(zero, cam);
  FrameMetadata nan = m;
  nan.exposure_s = NAN;
  EXPECT_NE(message_of(nan, cam).find("exposure_s"), std::string::npos);
  FrameMetadata no_gain = m;
  no_gain.gain_db.reset();
  EXPECT_NE(message_of(no_gain, cam).find("track.jsonl:7: no gain"), std::string::npos) << message_of(no_gain, cam);
  FrameMetadata nan_gain = m;
  nan_gain.gain_db = NAN;
  EXPECT_NE(message_of(nan_gain, cam).find("gain_db"), std::string::npos);
  FrameMetadata neg_iso = no_gain;
  neg_iso.iso = -100;
  EXPECT_NE(message_of(neg_iso, cam).find("iso"), std::string::npos);
  FrameMetadata code = m;
  code.mean_code = 1.5;
  EXPECT_NE(message_of(code, cam).find("mean_code"), std::string::npos);
  FrameMetadata wb = m;
  wb.wb_gains = std::array<double, 3>{1, 0, 1};
  EXPECT_NE(message_of(wb, cam).find("white-balance"), std::string::npos);
  MeteringOptions bad = cam;
  bad.ae_target = 0;
  EXPECT_THROW(validate_metering(bad), InputError);
}

// Nearest-rank percentiles of 1..21: rank round(p * 20), so 5 % -> 2, median 11, 95 % -> 20.
TEST(ReadingsSpread, NearestRankPercentilesAndCctOnlyWhereKnown) {
  std::vector<LightReading> readings;
  for (int i = 21; i >= 1; --i) {  // out of order on purpose
    LightReading r;
    r.luminance = i;
    r.illuminance = M_PI * i;
    r.cct_k = i <= 3 ? 3000.0 * i : 0.0;  // three readings with a colour temperature
    readings.push_back(r);
  }
  readings[0].cct_k = NAN;
  const ReadingsSpread s = readings_spread(readings);
  EXPECT_EQ(s.luminance.p05, 2);
  EXPECT_EQ(s.luminance.median, 11);
  EXPECT_EQ(s.luminance.p95, 20);
  EXPECT_DOUBLE_EQ(s.illuminance.median, M_PI * 11);
  EXPECT_EQ(s.with_cct, 3u);
  EXPECT_EQ(s.cct.p05, 3000);  // rank round(0.05 * 2) = 0
  EXPECT_EQ(s.cct.median, 6000);
  EXPECT_EQ(s.cct.p95, 9000);
  EXPECT_EQ(s.cct.to_json()["p95"], 9000);
  const ReadingsSpread none = readings_spread({});
  EXPECT_EQ(none.luminance.median, 0);
  EXPECT_EQ(none.with_cct, 0u);
}

}  // namespace
}  // namespace lp
