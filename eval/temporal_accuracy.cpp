#include "eval/temporal_accuracy.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/error.h"

namespace lp {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// The diffuse rel_rms of core/accuracy.h.
double rel_rms(const std::vector<double>& ref, const std::vector<double>& est) {
  if (ref.empty()) return 0;
  double sq = 0, mean = 0;
  for (size_t k = 0; k < ref.size(); ++k) {
    const double d = est[k] - ref[k];
    sq += d * d;
    mean += ref[k];
  }
  sq /= double(ref.size());
  mean /= double(ref.size());
  if (mean <= 0) return sq == 0 ? 0.0 : INFINITY;
  return std::sqrt(sq) / mean;
}

double mean_of(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? 0.0 : s / double(v.size());
}

}  // namespace

TemporalScorer::TemporalScorer(int directions) : normals_(fibonacci_sphere(directions)) {
  if (directions < 1) throw InputError("temporal scorer: directions must be at least 1");
}

void TemporalScorer::add_frame(const EnvMap& reference_map, std::span<const Light> lights) {
  AccuracyOptions options;
  options.directions = int(normals_.size());
  options.glossy_exponents.clear();
  options.shadowed = false;
  add_frame(make_accuracy_reference(reference_map, options).diffuse, lights);
}

void TemporalScorer::add_frame(const std::vector<double>& reference_irradiance, std::span<const Light> lights) {
  const size_t nd = normals_.size();
  if (reference_irradiance.size() != nd)
    throw InputError("temporal scorer: reference has " + std::to_string(reference_irradiance.size()) +
                     " normals, expected " + std::to_string(nd));

  // Ids and directions, checked for duplicates before anything is stored.
  std::vector<std::pair<uint64_t, Vec3>> current;
  current.reserve(lights.size());
  for (const Light& l : lights) current.emplace_back(l.id, l.direction);
  std::sort(current.begin(), current.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  for (size_t i = 1; i < current.size(); ++i)
    if (current[i].first == current[i - 1].first)
      throw InputError("temporal scorer: light id " + std::to_string(current[i].first) + " appears twice in frame " +
                       std::to_string(reference_.size()));

  std::vector<double> est(nd, 0.0);
  std::vector<double> lum(lights.size());
  for (size_t i = 0; i < lights.size(); ++i) lum[i] = lights[i].luminance();
  for (size_t k = 0; k < nd; ++k) {
    const Vec3 n = normals_[k];
    double e = 0;
    for (size_t i = 0; i < lights.size(); ++i) e += lum[i] * std::max(0.0, dot(n, lights[i].direction));
    est[k] = e;
  }

  // Jitter: ids present in both the previous frame and this one (merge of sorted lists).
  if (!reference_.empty()) {
    size_t a = 0, b = 0;
    while (a < previous_.size() && b < current.size()) {
      if (previous_[a].first < current[b].first) {
        ++a;
      } else if (current[b].first < previous_[a].first) {
        ++b;
      } else {
        jitter_sum_rad_ += angle_between(normalize(previous_[a].second), normalize(current[b].second));
        ++jitter_count_;
        ++a;
        ++b;
      }
    }
  }

  diffuse_error_.push_back(rel_rms(reference_irradiance, est));
  reference_.push_back(reference_irradiance);
  lights_.push_back(std::move(est));
  previous_ = std::move(current);
}

TemporalReport TemporalScorer::report(std::optional<int> step) const {
  TemporalReport r;
  const size_t nt = reference_.size(), nd = normals_.size();
  r.frames = int(nt);

  double ebar = 0;
  for (const auto& e : reference_) ebar += mean_of(e);
  ebar = nt ? ebar / double(nt) : 0.0;

  if (nt < 2) {
    r.flicker = kNaN;
  } else {
    double sum = 0;
    for (size_t t = 1; t < nt; ++t)
      for (size_t k = 0; k < nd; ++k) {
        const double dl = lights_[t][k] - lights_[t - 1][k];
        const double dr = reference_[t][k] - reference_[t - 1][k];
        sum += std::fabs(dl - dr);
      }
    const double mean = sum / double((nt - 1) * nd);
    r.flicker = ebar > 0 ? mean / ebar : (mean == 0 ? 0.0 : INFINITY);
  }

  r.jitter_deg = jitter_count_ ? jitter_sum_rad_ / double(jitter_count_) * 180.0 / M_PI : kNaN;

  r.lag_frames = kNaN;
  if (step) {
    const int s = *step;
    if (s < 1 || s >= int(nt))
      throw InputError("temporal scorer: step frame " + std::to_string(s) + " is outside 1.." +
                       std::to_string(int(nt) - 1));
    double pre = 0, post = 0;
    for (int t = 0; t < s; ++t) pre += mean_of(reference_[size_t(t)]);
    for (size_t t = size_t(s); t < nt; ++t) post += mean_of(reference_[t]);
    pre /= double(s);
    post /= double(nt - size_t(s));
    if (post != pre) {
      const double target = pre + 0.9 * (post - pre);
      r.lag_frames = INFINITY;
      for (size_t t = size_t(s); t < nt; ++t) {
        const double level = mean_of(lights_[t]);
        if (post > pre ? level >= target : level <= target) {
          r.lag_frames = double(t - size_t(s));
          break;
        }
      }
    }
  }

  r.mean_diffuse_error = nt ? mean_of(diffuse_error_) : kNaN;
  return r;
}

}  // namespace lp
