// Prometheus text exposition (format 0.0.4) for /metrics: families with HELP and TYPE,
// counters ending in _total, values in base units (seconds, bytes), and cumulative
// histograms. Output passes `promtool check metrics` (tests/live/system/metrics_promtool.sh).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace lp {

// Counts of observations per bucket of fixed upper bounds (increasing; +Inf implied).
// Not thread-safe: the owner guards it.
class Histogram {
 public:
  explicit Histogram(std::vector<double> upper_bounds);
  void observe(double value);  // NaN is ignored; +Inf lands in the +Inf bucket
  const std::vector<double>& bounds() const { return bounds_; }
  // Observations <= bounds()[k] (cumulative, as Prometheus reports them); k = bounds().size() is +Inf.
  uint64_t cumulative(size_t k) const;
  uint64_t count() const { return count_; }
  double sum() const { return sum_; }

 private:
  std::vector<double> bounds_;
  std::vector<uint64_t> counts_;  // per bucket, the last one above every bound
  uint64_t count_ = 0;
  double sum_ = 0;
};

// Buckets for latencies in seconds: 0.5 ms to 5 s, roughly 1-2-5.
std::vector<double> latency_buckets_seconds();

// "x" for a label value: backslash, double quote and newline escaped.
std::string prometheus_label_value(std::string_view value);

class MetricsText {
 public:
  // A family: "# HELP name help" and "# TYPE name type" (type: counter, gauge, histogram).
  void family(std::string_view name, std::string_view type, std::string_view help);
  // One sample of the current family; `labels` as written inside the braces, e.g.
  // stage="fuse" (values escaped with prometheus_label_value). Non-finite values are
  // written as Prometheus spells them (+Inf, -Inf, NaN).
  void sample(std::string_view name, double value, std::string_view labels = "");
  // name_bucket{...,le="..."} for every bound and +Inf, name_sum, name_count.
  void histogram(std::string_view name, const Histogram& h, std::string_view labels = "");
  void counter(std::string_view name, std::string_view help, double value);  // name must end in _total
  void gauge(std::string_view name, std::string_view help, double value);
  const std::string& text() const { return out_; }

 private:
  std::string out_;
};

}  // namespace lp
