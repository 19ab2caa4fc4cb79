// /metrics in Prometheus' terms (issue 18): histograms whose buckets count what was
// observed, in seconds, from a running pipeline; promtool's own check runs in
// tests/live/system/metrics_promtool.sh.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <string>
#include <thread>

#include "live/metrics.h"
#include "live/pipeline.h"

namespace lp {
namespace {

// The value of the sample written exactly as `series` ("name{labels}" or "name"); NaN if absent.
double sample(const std::string& text, const std::string& series) {
  const std::string key = series + " ";
  size_t pos = 0;
  while ((pos = text.find(key, pos)) != std::string::npos) {
    if (pos == 0 || text[pos - 1] == '\n') return std::stod(text.substr(pos + key.size()));
    pos += key.size();
  }
  return NAN;
}

TEST(Metrics, HistogramBucketsCountWhatWasObserved) {
  Histogram h({0.001, 0.01, 0.1});
  for (double v : {0.0005, 0.001, 0.005, 0.05, 0.5, 5.0, double(NAN)}) h.observe(v);
  EXPECT_EQ(h.count(), 6u);  // NaN is not an observation
  EXPECT_NEAR(h.sum(), 0.0005 + 0.001 + 0.005 + 0.05 + 0.5 + 5.0, 1e-15);
  EXPECT_EQ(h.cumulative(0), 2u);  // le is inclusive: 0.001 counts in le="0.001"
  EXPECT_EQ(h.cumulative(1), 3u);
  EXPECT_EQ(h.cumulative(2), 4u);
  EXPECT_EQ(h.cumulative(3), 6u);  // +Inf
  MetricsText m;
  m.family("x_seconds", "histogram", "A test.");
  m.histogram("x_seconds", h, "stage=\"a\\\"b\"");
  EXPECT_EQ(m.text(),
            "# HELP x_seconds A test.\n# TYPE x_seconds histogram\n"
            "x_seconds_bucket{stage=\"a\\\"b\",le=\"0.001\"} 2\n"
            "x_seconds_bucket{stage=\"a\\\"b\",le=\"0.01\"} 3\n"
            "x_seconds_bucket{stage=\"a\\\"b\",le=\"0.1\"} 4\n"
            "x_seconds_bucket{stage=\"a\\\"b\",le=\"+Inf\"} 6\n"
            "x_seconds_sum{stage=\"a\\\"b\"} 5.5565\n"
            "x_seconds_count{stage=\"a\\\"b\"} 6\n");
  EXPECT_EQ(prometheus_label_value("a\"b\\c\nd"), "a\\\"b\\\\c\\nd");
  EXPECT_THROW(Histogram({0.1, 0.01}), std::invalid_argument);
}

// A bracketing source as fast as the pipeline takes frames.
class Bracketing : public CameraSource {
 public:
  explicit Bracketing(int frames) : frames_(frames) {}
  std::string describe() const override { return "bracketing"; }
  void set_exposure_cycle(const std::vector<double>& s) override { cycle_ = s; }
  bool finished() const override { return produced_ >= frames_; }
  std::optional<CameraFrame> next(double) override {
    if (produced_ >= frames_) return std::nullopt;
    const size_t k = size_t(produced_ % int(cycle_.size()));
    CameraFrame f;
    f.exposure_s = cycle_[k];
    f.bracket_index = int(k);
    f.sequence = produced_++;
    f.image.width = f.image.height = 64;
    f.image.rgb.assign(64 * 64 * 3, float(std::min(1.0, 0.3 * f.exposure_s / 0.01)));
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    return f;
  }

 private:
  int frames_, produced_ = 0;
  std::vector<double> cycle_;
};

TEST(Metrics, PipelineHistogramsCountEveryPublishedListInSeconds) {
  LivePipelineOptions o;
  o.exposure_cycle = {0.001, 0.004, 0.016};
  o.width = 90;
  o.height = 23;
  o.sampling.method = Method::Pharr;
  o.sampling.count = 16;
  o.sampling.sampler.upper_only = true;
  o.queue_brackets = 1000;  // nothing dropped: every bracket is observed
  std::atomic<int> published{0};
  LivePipeline p([] { return std::make_unique<Bracketing>(60); }, o, [&](const LightList&, std::shared_ptr<const EnvMap>) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));  // a publish of known cost
    ++published;
  });
  p.start();
  p.wait();
  const std::string m = p.metrics();
  const double processed = sample(m, "lightprobe_brackets_processed_total");
  ASSERT_EQ(processed, 20);
  ASSERT_EQ(published.load(), 20);
  const std::string publish = "stage=\"publish\"";
  // Every list in each histogram, in seconds: the 20 ms publish is above 0.01 s every time.
  EXPECT_EQ(sample(m, "lightprobe_stage_duration_seconds_count{" + publish + "}"), processed);
  EXPECT_EQ(sample(m, "lightprobe_stage_duration_seconds_bucket{" + publish + ",le=\"+Inf\"}"), processed);
  EXPECT_EQ(sample(m, "lightprobe_stage_duration_seconds_bucket{" + publish + ",le=\"0.01\"}"), 0);
  EXPECT_GE(sample(m, "lightprobe_stage_duration_seconds_sum{" + publish + "}"), 0.020 * processed);
  EXPECT_LT(sample(m, "lightprobe_stage_duration_seconds_sum{" + publish + "}"), 1.0 * processed);
  // Brackets fuse and unwrap in one pass; the single-frame stages saw nothing.
  EXPECT_EQ(sample(m, "lightprobe_stage_duration_seconds_count{stage=\"fuse_unwrap\"}"), processed);
  EXPECT_EQ(sample(m, "lightprobe_stage_duration_seconds_count{stage=\"sample\"}"), processed);
  EXPECT_EQ(sample(m, "lightprobe_stage_duration_seconds_count{stage=\"fuse\"}"), 0);
  EXPECT_EQ(sample(m, "lightprobe_stage_duration_seconds_count{stage=\"unwrap\"}"), 0);
  // End to end includes the publish.
  EXPECT_EQ(sample(m, "lightprobe_latency_seconds_count"), processed);
  EXPECT_EQ(sample(m, "lightprobe_latency_seconds_bucket{le=\"0.01\"}"), 0);
  EXPECT_EQ(sample(m, "lightprobe_latency_seconds_bucket{le=\"+Inf\"}"), processed);
  // Buckets are cumulative.
  double previous = 0;
  for (const char* le : {"0.0005", "0.001", "0.002", "0.005", "0.01", "0.02", "0.05", "0.1", "0.2", "0.5", "1", "2", "5",
                         "+Inf"}) {
    const double v = sample(m, std::string("lightprobe_latency_seconds_bucket{le=\"") + le + "\"}");
    ASSERT_FALSE(std::isnan(v)) << le;
    EXPECT_GE(v, previous) << le;
    previous = v;
  }
  EXPECT_EQ(m.find("_ms"), std::string::npos) << "a metric not in seconds";
}

}  // namespace
}  // namespace lp
