#include "eval/hdr_eval.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <unistd.h>

#include "core/image_io.h"
#include "eval/synthetic_scene.h"

namespace lp {
namespace {

namespace fs = std::filesystem;

// The procedural scene as a small radiance file (128x64): brackets of it fuse in ms.
const EvalHdrReport& report() {
  static const EvalHdrReport r = [] {
    const fs::path dir = fs::path(::testing::TempDir()) / ("lp_hdr_eval_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    const std::string map = (dir / "small_scene.exr").string();
    write_rgb_image(map, image_from_envmap(render_scene(describe_scene(), Layout::LatLong, 128, 64)));
    EvalHdrOptions o;
    o.maps = {map};
    o.response = ResponseCurve::Gamma22;
    o.output_dir = (dir / "out").string();
    return evaluate_hdr(o);
  }();
  return r;
}

TEST(HdrEval, SixFusionsPerMapLabelledByTheFileName) {
  const EvalHdrReport& r = report();
  ASSERT_EQ(r.rows.size(), 6u);
  EXPECT_EQ(r.rows[0].map, "small_scene");
  EXPECT_EQ(r.rows[0].method, "ours (true response)");
  EXPECT_EQ(r.rows[5].method, "OpenCV MergeRobertson (true response)");
  EXPECT_EQ(r.to_json()["rows"].size(), 6u);
  EXPECT_TRUE(fs::exists(r.csv_path));
  EXPECT_TRUE(fs::exists(r.svg_path));
  for (const HdrRow& row : r.rows) EXPECT_GT(row.floor_ms, 0);
}

TEST(HdrEval, OurMergeWithTheTrueResponseRecoversTheRadiance) {
  const EvalHdrReport& r = report();
  // Measured 0.0043 and 0.013 log10: 8-bit codes with shot and read noise; a response
  // taken for the wrong curve is off by tenths.
  EXPECT_LT(r.rows[0].error.median_log10, 0.01);
  EXPECT_LT(r.rows[0].error.p95_log10, 0.03);
  EXPECT_EQ(r.rows[0].recover_ms, 0);  // nothing to recover
  // A recovered response cannot beat the true one by much.
  EXPECT_GT(r.rows[1].error.p95_log10, 0.5 * r.rows[0].error.p95_log10);
}

}  // namespace
}  // namespace lp
