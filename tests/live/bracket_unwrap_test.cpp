// Fusing only the footprints the unwrap reads gives the map that merging every pixel and
// then unwrapping gives: bit for bit, with the sun clipped in two of three exposures, with
// ghost masks and with frames' own valid masks.
#include <gtest/gtest.h>

#include <cmath>

#include "calib/camera_model.h"
#include "core/error.h"
#include "live/bracket_unwrap.h"
#include "probe/camera_source.h"
#include "probe/camera_unwrap.h"
#include "probe/fisheye.h"

namespace lp {
namespace {

constexpr int kW = 320, kH = 240;

Bracket fake_bracket() {
  FakeScene scene;
  scene.sun_radius_deg = 6;  // several footprints straddle its edge at this size
  const RgbImage radiance = render_fake_scene(scene, kW, kH);
  Bracket b;
  b.exposure_seconds = {0.00004, 0.0004, 0.004};
  for (double t : b.exposure_seconds) {
    RgbImage f = radiance;
    for (float& v : f.rgb) v = std::round(std::min(1.0f, float(v * t)) * 255.0f) / 255.0f;
    b.frames.push_back(std::move(f));
  }
  return b;
}

CompiledRemap hemisphere_remap() {
  const CameraModel model = camera_model_from_fisheye(equidistant_fisheye(kW, kH, 180));
  return compile_remap(camera_remap(model, upward_camera_world_from_camera(), Layout::Hemisphere, 180, 45, 90), kW, kH);
}

void expect_identical(const RgbImage& a, const RgbImage& b) {
  ASSERT_EQ(a.width, b.width);
  ASSERT_EQ(a.height, b.height);
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  EXPECT_EQ(a.valid, b.valid);
  size_t differing = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i)
    if (!(a.rgb[i] == b.rgb[i])) ++differing;
  EXPECT_EQ(differing, 0u);
}

TEST(BracketUnwrap, EqualsMergingEveryPixelThenUnwrapping) {
  const Bracket b = fake_bracket();
  const CompiledRemap remap = hemisphere_remap();
  const CameraResponse response = linear_response(256);
  RgbImage reference;
  apply_remap(merge_bracket(b, response), remap, &reference);
  const RgbImage fused = fuse_and_unwrap(b, response, {}, plan_bracket_unwrap(remap));
  expect_identical(fused, reference);
  // The scene has a clipped sun, so the comparison covers saturated footprints: the sun's
  // map pixels are far brighter than the sky's.
  float peak = 0;
  for (float v : fused.rgb) peak = std::max(peak, v);
  EXPECT_GT(peak, 5000.0f);
}

TEST(BracketUnwrap, GhostMasksAndFrameValidMasksAreGatheredToo) {
  Bracket b = fake_bracket();
  const size_t n = size_t(kW) * kH;
  MergeOptions options;
  for (int k = 0; k < 3; ++k) {
    std::vector<uint8_t> mask(n, 1);
    for (size_t i = size_t(k) * 7; i < n; i += 13) mask[i] = 0;  // a different sparse pattern per frame
    options.frame_masks.push_back(mask);
  }
  b.frames[1].valid.assign(n, 1);
  for (size_t i = 0; i < n / 3; ++i) b.frames[1].valid[i] = 0;  // the top third shifted in by alignment
  const CompiledRemap remap = hemisphere_remap();
  const CameraResponse response = linear_response(256);
  RgbImage reference;
  apply_remap(merge_bracket(b, response, options), remap, &reference);
  expect_identical(fuse_and_unwrap(b, response, options, plan_bracket_unwrap(remap)), reference);
}

TEST(BracketUnwrap, AFrameOfAnotherSizeIsAnInputError) {
  Bracket b = fake_bracket();
  b.frames[2].width = kW / 2;
  const CompiledRemap remap = hemisphere_remap();
  EXPECT_THROW(fuse_and_unwrap(b, linear_response(256), {}, plan_bracket_unwrap(remap)), InputError);
}

// A workspace kept from bracket to bracket (as the stream keeps it) carries nothing over: a
// bracket with valid masks, then one without, then a darker one give each the map a fresh
// call gives, bit for bit.
TEST(BracketUnwrap, AReusedWorkspaceGivesTheMapOfAFreshCall) {
  const CompiledRemap remap = hemisphere_remap();
  const BracketUnwrapPlan plan = plan_bracket_unwrap(remap);
  const CameraResponse response = linear_response(256);
  Bracket masked = fake_bracket();
  masked.frames[0].valid.assign(size_t(kW) * kH, 1);
  for (size_t i = 0; i < masked.frames[0].valid.size(); i += 5) masked.frames[0].valid[i] = 0;
  Bracket plain = fake_bracket();
  Bracket darker = fake_bracket();
  for (RgbImage& f : darker.frames)
    for (float& v : f.rgb) v = std::round(v * 0.5f * 255.0f) / 255.0f;
  FuseUnwrapWorkspace workspace;
  for (const Bracket* b : {&masked, &plain, &darker, &masked}) {
    const RgbImage fresh = fuse_and_unwrap(*b, response, {}, plan);
    expect_identical(fuse_and_unwrap(*b, response, {}, plan, {}, &workspace), fresh);
  }
  RgbImage reference;  // and the reused result is still the right one
  apply_remap(merge_bracket(darker, response), remap, &reference);
  expect_identical(fuse_and_unwrap(darker, response, {}, plan, {}, &workspace), reference);
}

// Masks are read by the remap's indices: one of the wrong size is refused, not read past.
TEST(BracketUnwrap, MasksOfTheWrongSizeAreAnInputError) {
  const CompiledRemap remap = hemisphere_remap();
  const BracketUnwrapPlan plan = plan_bracket_unwrap(remap);
  Bracket b = fake_bracket();
  b.frames[1].valid.assign(10, 1);
  EXPECT_THROW(fuse_and_unwrap(b, linear_response(256), {}, plan), InputError);
  MergeOptions options;
  options.frame_masks.assign(3, std::vector<uint8_t>(10, 1));
  EXPECT_THROW(fuse_and_unwrap(fake_bracket(), linear_response(256), options, plan), InputError);
}

}  // namespace
}  // namespace lp
