#include "live/metrics.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include <fmt/format.h>

namespace lp {

Histogram::Histogram(std::vector<double> upper_bounds) : bounds_(std::move(upper_bounds)) {
  for (size_t k = 0; k < bounds_.size(); ++k)
    if (!std::isfinite(bounds_[k]) || (k > 0 && !(bounds_[k] > bounds_[k - 1])))
      throw std::invalid_argument("Histogram: bounds must be finite and increasing");
  counts_.assign(bounds_.size() + 1, 0);
}

void Histogram::observe(double value) {
  if (std::isnan(value)) return;
  const size_t k = size_t(std::lower_bound(bounds_.begin(), bounds_.end(), value) - bounds_.begin());
  ++counts_[k];
  ++count_;
  sum_ += value;
}

uint64_t Histogram::cumulative(size_t k) const {
  uint64_t n = 0;
  for (size_t i = 0; i <= std::min(k, bounds_.size()); ++i) n += counts_[i];
  return n;
}

std::vector<double> latency_buckets_seconds() {
  return {0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5};
}

std::string prometheus_label_value(std::string_view value) {
  std::string out;
  out.reserve(value.size());
  for (char c : value) {
    if (c == '\n') {
      out += "\\n";
      continue;
    }
    if (c == '\\' || c == '"') out += '\\';
    out += c;
  }
  return out;
}

namespace {

std::string number(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
  return fmt::format("{}", v);
}

}  // namespace

void MetricsText::family(std::string_view name, std::string_view type, std::string_view help) {
  out_ += fmt::format("# HELP {} {}\n# TYPE {} {}\n", name, help, name, type);
}

void MetricsText::sample(std::string_view name, double value, std::string_view labels) {
  if (labels.empty()) out_ += fmt::format("{} {}\n", name, number(value));
  else out_ += fmt::format("{}{{{}}} {}\n", name, labels, number(value));
}

void MetricsText::histogram(std::string_view name, const Histogram& h, std::string_view labels) {
  const std::string sep = labels.empty() ? "" : ",";
  for (size_t k = 0; k <= h.bounds().size(); ++k) {
    const std::string le = k < h.bounds().size() ? number(h.bounds()[k]) : "+Inf";
    out_ += fmt::format("{}_bucket{{{}{}le=\"{}\"}} {}\n", name, labels, sep, le, h.cumulative(k));
  }
  sample(std::string(name) + "_sum", h.sum(), labels);
  sample(std::string(name) + "_count", double(h.count()), labels);
}

void MetricsText::counter(std::string_view name, std::string_view help, double value) {
  family(name, "counter", help);
  sample(name, value);
}

void MetricsText::gauge(std::string_view name, std::string_view help, double value) {
  family(name, "gauge", help);
  sample(name, value);
}

}  // namespace lp
