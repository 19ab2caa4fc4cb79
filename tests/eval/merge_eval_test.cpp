// eval merge as a library call (issue 20 item 4): four displaced cameras around a target
// in the synthetic room, merged with equal weights and with position weights, scored
// against a camera placed at the target. Position weights must win off the centre; at the
// centre every weighting is the same merge, and at a camera's own place 1/d^2 is that camera.
#include <unistd.h>  // getpid: ctest runs each test in its own process, at once

#include "eval/merge_eval.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>

#include "core/error.h"

namespace lp {
namespace {

namespace fs = std::filesystem;

const MergeEvalRow& row(const EvalMergeReport& r, const std::string& method, const std::string& weighting, double x, double y) {
  for (const MergeEvalRow& e : r.rows)
    if (e.method == method && e.weighting == weighting && std::abs(e.target.x - x) < 1e-9 && std::abs(e.target.y - y) < 1e-9)
      return e;
  throw std::runtime_error("no row " + method + " " + weighting);
}

const MergeEvalSummary& mean(const EvalMergeReport& r, const std::string& method, const std::string& weighting) {
  for (const MergeEvalSummary& s : r.summary_rows)
    if (s.method == method && s.weighting == weighting) return s;
  throw std::runtime_error("no summary " + method + " " + weighting);
}

TEST(MergeEval, PositionWeightsBeatEqualWeightsAtTargetsOffTheCentre) {
  EvalMergeOptions o;
  o.grid = 3;  // the four cameras, the four edge midpoints and the centre
  o.output_dir = (fs::temp_directory_path() / ("lightprobe_merge_eval_" + std::to_string(::getpid()))).string();
  const EvalMergeReport r = evaluate_merge(o);
  EXPECT_EQ(r.rows.size(), 2u * 9u * 4u);  // methods x targets x (target camera, equal, 1/d, 1/d^2)
  EXPECT_TRUE(fs::exists(r.csv_path));
  EXPECT_TRUE(fs::exists(r.chart_path));
  const Vec3 c = o.centre;
  for (const std::string method : {"pharr", "q2tree"}) {
    SCOPED_TRACE(method);
    // The centre: every camera 0.71 m away, so every weighting is the equal merge.
    EXPECT_DOUBLE_EQ(row(r, method, "1/d^2", c.x, c.y).diffuse, row(r, method, "equal", c.x, c.y).diffuse);
    // A corner is a camera's place: 1/d^2 gives it all the weight, and its lights are what
    // a camera there sees (the floor of the yardstick).
    EXPECT_NEAR(row(r, method, "1/d^2", c.x - 0.5, c.y - 0.5).diffuse,
                row(r, method, "target camera", c.x - 0.5, c.y - 0.5).diffuse, 1e-12);
    const MergeEvalSummary& equal = mean(r, method, "equal");
    const MergeEvalSummary& weighted = mean(r, method, "1/d^2");
    EXPECT_EQ(weighted.targets, 8);
    EXPECT_EQ(weighted.wins_over_equal, 8);
    EXPECT_LT(weighted.diffuse, 0.6 * equal.diffuse);
    EXPECT_LT(mean(r, method, "1/d^1").diffuse, equal.diffuse);
    EXPECT_LT(mean(r, method, "target camera").diffuse, weighted.diffuse);  // merging costs something
  }
  const auto j = r.to_json();
  EXPECT_EQ(j["summary"].size(), 8u);
  EXPECT_NE(r.summary().find("1/d^2"), std::string::npos);
  fs::remove_all(o.output_dir);
}

TEST(MergeEval, BadOptionsAreRefused) {
  EvalMergeOptions o;
  o.grid = 1;
  EXPECT_THROW(evaluate_merge(o), InputError);
  o.grid = 3;
  o.powers = {-1};
  EXPECT_THROW(evaluate_merge(o), InputError);
}

}  // namespace
}  // namespace lp
