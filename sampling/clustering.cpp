#include "sampling/clustering.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

#include "core/error.h"

namespace lp {
namespace {

struct Clusterer {
  const std::vector<Light>& lights;
  std::vector<int> order;        // light indices sorted by zenith angle
  std::vector<double> theta;     // zenith angle of order[i]
  std::vector<int> rank;         // position of light i in `order`
  std::vector<int> next;         // next unassigned position >= i in `order` (n = end)
  std::vector<int> cluster_of;   // cluster index of each light, -1 = unassigned

  explicit Clusterer(const std::vector<Light>& l) : lights(l) {
    const int n = static_cast<int>(lights.size());
    order.resize(n);
    std::iota(order.begin(), order.end(), 0);
    std::vector<double> th(n);
    for (int i = 0; i < n; ++i) th[i] = zenith_of(lights[i].direction);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return th[a] < th[b]; });
    theta.resize(n);
    rank.resize(n);
    for (int i = 0; i < n; ++i) {
      theta[i] = th[order[i]];
      rank[order[i]] = i;
    }
  }

  int find_next(int i) {
    int root = i;
    while (root < static_cast<int>(next.size()) - 1 && next[root] != root) root = next[root];
    while (i != root) {
      const int up = next[i];
      next[i] = root;
      i = up;
    }
    return root;
  }
  void mark_assigned(int pos) { next[pos] = pos + 1; }

  // Cluster seeds (light indices) for radius eps, or an empty vector as soon as there are
  // more than max_clusters.
  std::vector<int> run(double eps, int max_clusters) {
    const int n = static_cast<int>(lights.size());
    next.resize(n + 1);
    std::iota(next.begin(), next.end(), 0);
    cluster_of.assign(n, -1);
    const double cos_eps = eps >= M_PI ? -2.0 : std::cos(eps);
    constexpr double kBandSlack = 1e-12;
    std::vector<int> seeds;
    for (int i = 0; i < n; ++i) {
      if (cluster_of[i] >= 0) continue;
      if (static_cast<int>(seeds.size()) == max_clusters) return {};
      const int c = static_cast<int>(seeds.size());
      seeds.push_back(i);
      cluster_of[i] = c;
      mark_assigned(rank[i]);
      const Vec3 d = lights[i].direction;
      const double th = theta[rank[i]];
      const int lo = static_cast<int>(std::lower_bound(theta.begin(), theta.end(), th - eps - kBandSlack) - theta.begin());
      const double hi = th + eps + kBandSlack;
      for (int p = find_next(lo); p < n && theta[p] <= hi; p = find_next(p + 1)) {
        const int j = order[p];
        if (dot(d, lights[j].direction) >= cos_eps) {
          cluster_of[j] = c;
          mark_assigned(p);
        }
      }
    }
    return seeds;
  }
};

}  // namespace

double cluster_radius(int max_lights, const ClusterOptions& options) {
  if (max_lights < 1) throw InputError("clustering: the maximum number of lights must be at least 1, not " +
                                       std::to_string(max_lights));
  if (!(options.correction > 0) || !std::isfinite(options.correction))
    throw InputError("clustering: the correction factor must be positive");
  const double share = (options.upper_hemisphere_only ? 2.0 : 4.0) / max_lights;
  return options.correction * std::asin(std::sqrt(std::min(1.0, share)));
}

std::vector<Light> cluster_lights(const std::vector<Light>& lights, int max_lights, const ClusterOptions& options) {
  double eps = cluster_radius(max_lights, options);
  if (lights.empty()) return {};
  Clusterer clusterer(lights);
  std::vector<int> seeds;
  for (;;) {
    seeds = clusterer.run(eps, max_lights);
    if (!seeds.empty()) break;
    eps *= 1.1;  // reaches pi within a few dozen steps, where one cluster holds everything
  }
  const size_t m = seeds.size();
  std::vector<Light> out(m);
  std::vector<Vec3> mean(m);
  for (size_t c = 0; c < m; ++c) {
    out[c].id = lights[seeds[c]].id;
    out[c].direction = lights[seeds[c]].direction;
  }
  for (size_t i = 0; i < lights.size(); ++i) {
    const int c = clusterer.cluster_of[i];
    Light& o = out[c];
    mean[c] = mean[c] + lights[i].direction;
    for (int k = 0; k < 3; ++k) o.rgb[k] += lights[i].rgb[k];
    o.solid_angle += lights[i].solid_angle;
  }
  for (size_t c = 0; c < m; ++c) {
    const double len = length(mean[c]);
    if (len > 1e-12) out[c].direction = (1.0 / len) * mean[c];
  }
  return out;
}

}  // namespace lp
