// The live back end on the dynamic scenarios where the papers say methods fail.
#include <gtest/gtest.h>

#include <cmath>

#include "core/accuracy.h"
#include "core/error.h"
#include "eval/synthetic_scene.h"
#include "eval/synthetic_sequence.h"
#include "eval/temporal_accuracy.h"
#include "sampling/frame_pipeline.h"

namespace lp {
namespace {

const EnvMap& base_map() {
  static const EnvMap map = render_scene(describe_scene(), Layout::LatLong, 256, 128);
  return map;
}

TemporalReport run(Scenario scenario, Method method, int frames, FilterMode filter = FilterMode::Auto,
                   int count = 128) {
  SequenceOptions so;
  so.scenario = scenario;
  so.frames = frames;
  FramePipelineOptions po;
  po.method = method;
  po.count = count;
  po.filter = filter;
  FramePipeline pipeline(po);
  TemporalScorer scorer;
  for (int f = 0; f < frames; ++f) {
    const EnvMap frame = render_sequence_frame(base_map(), so, f);
    scorer.add_frame(frame, pipeline.process(frame, f, f / 21.0).lights);
  }
  return scorer.report(scenario == Scenario::AbruptSwitch ? std::optional<int>(step_frame(so)) : std::nullopt);
}

TEST(FramePipeline, HemigonJittersLessThanPharrOnAStaticSceneWithSensorNoise) {
  const double hemigon = run(Scenario::StaticNoise, Method::Hemigon, 24).jitter_deg;
  const double pharr = run(Scenario::StaticNoise, Method::Pharr, 24).jitter_deg;
  EXPECT_LT(hemigon, pharr);
  EXPECT_GT(pharr, 0.05);  // noise really moves equal-power lights
}

TEST(FramePipeline, Q2TreeFollowsAnAbruptSwitchWithinOneFrame) {
  EXPECT_LE(run(Scenario::AbruptSwitch, Method::Q2Tree, 24).lag_frames, 1.0);
}

TEST(FramePipeline, FilteredHemigonLagsAnAbruptSwitchByTheFilterStepResponse) {
  // Independent expectation from the taps alone: the first frame whose running sum of
  // taps reaches 90 % (the FIR's step response); 4 frames of group delay plus one.
  const FirFilter fir = havran2005_filter();
  double sum = 0;
  int expected = -1;
  for (size_t k = 0; k < fir.taps.size(); ++k) {
    sum += fir.taps[k];
    if (sum >= 0.9) {
      expected = int(k);
      break;
    }
  }
  ASSERT_EQ(expected, fir.delay_frames() + 1);
  const TemporalReport filtered = run(Scenario::AbruptSwitch, Method::Hemigon, 24);
  EXPECT_EQ(filtered.lag_frames, expected);
  // Without the filter hemigon follows at once.
  EXPECT_LE(run(Scenario::AbruptSwitch, Method::Hemigon, 24, FilterMode::Off).lag_frames, 1.0);
}

// `sample --n auto` hands its report's reference (both lobes, no caps) to the pipeline
// instead of letting it build its own: the same count and the same lights, bit for bit; a
// reference without the measure's lobe is refused, not misread.
TEST(FramePipeline, AutoCountWithTheCallersReferenceChoosesWhatItsOwnWould) {
  FramePipelineOptions po;
  po.method = Method::Pharr;
  po.auto_count = true;
  po.auto_options.measure = ErrorMeasure::Glossy100;
  po.auto_options.target_error = 0.15;
  FramePipeline own(po), given(po);
  AccuracyOptions report;  // both lobes
  report.shadowed = false;
  const AccuracyReference reference = make_accuracy_reference(base_map(), report);
  const LightList a = own.process(base_map(), 0, 0);
  const LightList b = given.process(base_map(), 0, 0, &reference);
  ASSERT_EQ(a.lights.size(), b.lights.size());
  EXPECT_GT(a.lights.size(), 1u);
  for (size_t i = 0; i < a.lights.size(); ++i) {
    EXPECT_EQ(a.lights[i].direction.x, b.lights[i].direction.x) << i;
    EXPECT_EQ(a.lights[i].rgb, b.lights[i].rgb) << i;
  }
  EXPECT_EQ(own.last_count().error, given.last_count().error);

  AccuracyOptions diffuse_only = report;
  diffuse_only.glossy_exponents.clear();
  const AccuracyReference lacking = make_accuracy_reference(base_map(), diffuse_only);
  FramePipeline refused(po);
  EXPECT_THROW(refused.process(base_map(), 0, 0, &lacking), InputError);
}

TEST(FramePipeline, ClusteringBoundsTheLightCountAndKeepsPower) {
  FramePipelineOptions po;
  po.method = Method::Pharr;
  po.count = 300;
  po.cluster_max_lights = 40;
  FramePipeline pipeline(po);
  const LightList list = pipeline.process(base_map(), 0, 0);
  EXPECT_LE(list.lights.size(), 40u);
  const auto want = total_power(base_map()), got = total_power(list.lights);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 1e-6 * want[c]);
}

TEST(FramePipeline, AutoCountPerFrameMeetsTheTargetOnEveryFrame) {
  FramePipelineOptions po;
  po.method = Method::Q2Tree;
  po.auto_count = true;
  po.auto_options.target_error = 0.01;
  FramePipeline pipeline(po);
  SequenceOptions so;
  so.scenario = Scenario::MovingLight;
  so.frames = 6;
  AccuracyOptions ao;
  ao.shadowed = false;
  for (int f = 0; f < so.frames; ++f) {
    const EnvMap frame = render_sequence_frame(base_map(), so, f);
    const LightList list = pipeline.process(frame, f, 0);
    EXPECT_LE(light_error(make_accuracy_reference(frame, ao), list.lights).diffuse, 0.01) << f;
  }
}

// --frame-budget-ms: a budget no frame can meet holds the count at min_count from the
// second frame on (and says so); a budget every frame meets never changes the count the
// error target chooses. Neither depends on this machine's speed.
TEST(FramePipeline, AFrameBudgetCapsTheAutoCountAndOnlyThen) {
  FramePipelineOptions po;
  po.method = Method::Pharr;
  po.auto_count = true;
  po.auto_options.target_error = 0.002;
  FramePipeline free_running(po);
  po.budget.budget_ms = 1e-6;
  FramePipeline starved(po);
  po.budget.budget_ms = 1e9;
  FramePipeline generous(po);
  for (int f = 0; f < 3; ++f) {
    const LightList a = free_running.process(base_map(), f, 0);
    const LightList b = starved.process(base_map(), f, 0);
    const LightList c = generous.process(base_map(), f, 0);
    EXPECT_GT(a.lights.size(), 64u) << "a target that needs many lights";
    EXPECT_EQ(c.lights.size(), a.lights.size()) << f;
    EXPECT_FALSE(generous.last_count().budget_limited);
    if (f == 0) {  // the first frame is measured before anything is capped
      EXPECT_EQ(b.lights.size(), a.lights.size());
    } else {
      EXPECT_EQ(int(b.lights.size()), po.auto_options.min_count) << f;
      EXPECT_TRUE(starved.last_count().budget_limited);
      EXPECT_FALSE(starved.last_count().reached);  // and the error says what the cap cost
      EXPECT_GT(starved.last_count().error, po.auto_options.target_error);
    }
    EXPECT_EQ(starved.last_count().budget_cap, po.auto_options.min_count);
  }
  FramePipelineOptions fixed;
  fixed.budget.budget_ms = 10;
  EXPECT_THROW(FramePipeline{fixed}, InputError);  // a budget caps --n auto only
}

TEST(FramePipeline, RejectsANonPositiveCount) {
  FramePipelineOptions po;
  po.count = 0;
  EXPECT_THROW(FramePipeline{po}, InputError);
}

}  // namespace
}  // namespace lp
