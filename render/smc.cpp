#include "render/smc.h"

#include <fmt/format.h>

#include <cmath>

#include "core/error.h"

namespace lp {

void validate(const SmcOptions& o) {
  if (o.particles < 1) throw InputError(fmt::format("smc: particles must be >= 1, got {}", o.particles));
  if (o.proposals_per_particle < 1)
    throw InputError(fmt::format("smc: proposals_per_particle must be >= 1, got {}", o.proposals_per_particle));
  if (!(o.ess_fraction >= 0 && o.ess_fraction <= 1))
    throw InputError(fmt::format("smc: ess_fraction must be in [0, 1], got {}", o.ess_fraction));
  if (o.mh_moves < 0) throw InputError(fmt::format("smc: mh_moves must be >= 0, got {}", o.mh_moves));
  if (o.reset_every < 0) throw InputError(fmt::format("smc: reset_every must be >= 0, got {}", o.reset_every));
  if (o.intermediate < 0) throw InputError(fmt::format("smc: intermediate must be >= 0, got {}", o.intermediate));
  if (!(o.local_move_probability >= 0 && o.local_move_probability <= 1))
    throw InputError(fmt::format("smc: local_move_probability must be in [0, 1], got {}", o.local_move_probability));
  if (!(o.independent_map_share >= 0 && o.independent_map_share <= 1))
    throw InputError(fmt::format("smc: independent_map_share must be in [0, 1], got {}", o.independent_map_share));
  if (!(o.init_proposal_map_share >= 0 && o.init_proposal_map_share <= 1))
    throw InputError(fmt::format("smc: init_proposal_map_share must be in [0, 1], got {}", o.init_proposal_map_share));
  if (!(o.local_move_deg > 0 && o.local_move_deg <= 180))
    throw InputError(fmt::format("smc: local_move_deg must be in (0, 180], got {}", o.local_move_deg));
}

SmcEstimator::SmcEstimator(ShadingPoint point, const SmcOptions& options, uint64_t seed)
    : point_(std::move(point)), options_(options), rng_(seed, 0x5EC) {
  validate(point_);
  validate(options_);
}

double SmcEstimator::bridge(double beta, const EnvDistribution& prev, const EnvDistribution& cur, Vec3 w) const {
  if (beta >= 1) return product_target(cur, point_, w);
  if (beta <= 0) return product_target(prev, point_, w);
  const double a = product_target(prev, point_, w);
  if (a <= 0) return 0;
  const double b = product_target(cur, point_, w);
  if (b <= 0) return 0;
  return std::pow(a, 1 - beta) * std::pow(b, beta);
}

void SmcEstimator::initialise(const EnvDistribution& map) {
  const int n = options_.particles;
  Resampled r = sample_importance_resample(map, point_, n * options_.proposals_per_particle, n,
                                           options_.init_proposal_map_share, rng_);
  dir_ = std::move(r.directions);
  gamma_ = std::move(r.target);
  weight_.assign(dir_.size(), dir_.empty() ? 0.0 : 1.0 / double(dir_.size()));
  z_ = r.z;
}

void SmcEstimator::reweight(double b1, const EnvDistribution& prev, const EnvDistribution& cur) {
  double sum = 0;
  for (size_t i = 0; i < dir_.size(); ++i) {
    const double g = bridge(b1, prev, cur, dir_[i]);
    weight_[i] = gamma_[i] > 0 ? weight_[i] * g / gamma_[i] : 0.0;
    gamma_[i] = g;
    sum += weight_[i];
  }
  ratio_sum_ = sum;
  z_ *= sum;
  double sq = 0;
  if (sum > 0)
    for (double& w : weight_) {
      w /= sum;
      sq += w * w;
    }
  stats_.last_ess = sq > 0 ? 1.0 / sq : 0.0;
}

void SmcEstimator::maybe_resample() {
  const size_t n = dir_.size();
  if (n == 0 || stats_.last_ess >= options_.ess_fraction * double(n)) return;
  std::vector<Vec3> d;
  std::vector<double> g;
  d.reserve(n);
  g.reserve(n);
  const double u0 = rng_.uniform();
  double cum = weight_[0];
  size_t j = 0;
  for (size_t i = 0; i < n; ++i) {
    const double t = (double(i) + u0) / double(n);
    while (j + 1 < n && cum <= t) cum += weight_[++j];
    d.push_back(dir_[j]);
    g.push_back(gamma_[j]);
  }
  dir_ = std::move(d);
  gamma_ = std::move(g);
  weight_.assign(n, 1.0 / double(n));
  ++stats_.resamples;
  stats_.last_resampled = true;
}

void SmcEstimator::move(double beta, const EnvDistribution& prev, const EnvDistribution& cur) {
  const double cos_cap = std::cos(options_.local_move_deg * M_PI / 180.0);
  const double s = options_.independent_map_share;
  auto independent_q = [&](Vec3 w) {
    return s * (s > 0 ? cur.pdf(w) : 0.0) + (1 - s) * (s < 1 ? lobe_pdf(point_.brdf, point_.normal, point_.view, w) : 0.0);
  };
  for (size_t i = 0; i < dir_.size(); ++i) {
    for (int m = 0; m < options_.mh_moves; ++m) {
      ++stats_.proposed;
      const Vec3 w = dir_[i];
      Vec3 proposal;
      double q_ratio = 1;  // q(w' -> w) / q(w -> w')
      if (rng_.uniform() < options_.local_move_probability) {
        // Uniform in the cap of half-angle delta about w: symmetric, so q cancels.
        const double z = 1 - rng_.uniform() * (1 - cos_cap);
        const double r = std::sqrt(std::max(0.0, 1 - z * z)), phi = 2 * M_PI * rng_.uniform();
        Vec3 t, b;
        orthonormal_basis(w, &t, &b);
        proposal = normalize(r * std::cos(phi) * t + r * std::sin(phi) * b + z * w);
      } else {
        if (rng_.uniform() < s) {
          proposal = cur.sample(rng_.uniform3()).direction;
        } else {
          const double u1 = rng_.uniform(), u2 = rng_.uniform();
          const LobeSample ls = sample_lobe(point_.brdf, point_.normal, point_.view, u1, u2);
          if (!ls.valid) continue;
          proposal = ls.direction;
        }
        const double q_new = independent_q(proposal), q_old = independent_q(w);
        if (!(q_new > 0)) continue;
        q_ratio = q_old / q_new;
      }
      const double g = bridge(beta, prev, cur, proposal);
      if (!(g > 0)) continue;
      const double a = g * q_ratio / gamma_[i];
      if (a >= 1 || rng_.uniform() < a) {
        dir_[i] = proposal;
        gamma_[i] = g;
        ++stats_.accepted;
      }
    }
  }
}

Rgb SmcEstimator::step(std::shared_ptr<const EnvDistribution> frame) {
  if (!frame) throw InputError("smc: no frame");
  const EnvDistribution& cur = *frame;
  stats_.last_reset = stats_.last_resampled = false;
  bool reset = !previous_ || dir_.empty() || (options_.reset_every > 0 && frames_since_reset_ >= options_.reset_every);
  if (!reset && options_.map_power_reset_ratio > 1) {
    const double r = cur.luminance_power() / previous_->luminance_power();
    reset = r > options_.map_power_reset_ratio || r < 1 / options_.map_power_reset_ratio;
  }
  if (!reset) {
    const EnvDistribution& prev = *previous_;
    const double z_prev = z_;
    const int steps = options_.intermediate + 1;
    for (int k = 1; k <= steps && !reset; ++k) {
      const double b1 = double(k) / steps;
      reweight(b1, prev, cur);  // from the bridge at (k - 1) / steps, held in gamma_
      if (!(ratio_sum_ > 0)) {
        reset = true;  // every particle fell where the new target is zero
        break;
      }
      maybe_resample();
      move(b1, prev, cur);
    }
    if (!reset && options_.reset_ratio > 1 && z_prev > 0) {
      const double r = z_ / z_prev;
      reset = r > options_.reset_ratio || r < 1 / options_.reset_ratio;
    }
  }
  if (reset) {
    if (previous_) {
      ++stats_.resets;
      stats_.last_reset = true;
    }
    initialise(cur);  // frame 0 and every reset are exactly BIS (unbiased)
    frames_since_reset_ = 0;
  }
  ++frames_since_reset_;
  ++stats_.frames;
  previous_ = std::move(frame);
  Rgb sum{0, 0, 0};
  for (size_t i = 0; i < dir_.size(); ++i) {
    const Rgb c = colour_ratio(cur, point_, dir_[i]);
    for (int ch = 0; ch < 3; ++ch) sum[ch] += weight_[i] * c[ch];
  }
  return {z_ * sum[0], z_ * sum[1], z_ * sum[2]};
}

}  // namespace lp
