// Merging several cameras' light lists: see merge_cameras.h.
#include "sampling/merge_cameras.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <map>
#include <queue>
#include <unordered_set>

#include "core/error.h"
#include "core/limits.h"

#include "core/healpix.h"

namespace lp {
namespace {

constexpr int kMaxLevel = 29;  // 12 * 4^29 finest-level ranges fit in 64 bits

// Weights normalised to sum 1 (empty: equal).
std::vector<double> normalised_weights(size_t count, const std::vector<double>& weights, const char* who) {
  if (count == 0) throw InputError(fmt::format("{}: no cameras to merge", who));
  if (weights.empty()) return std::vector<double>(count, 1.0 / double(count));
  if (weights.size() != count)
    throw InputError(fmt::format("{}: {} weights for {} cameras", who, weights.size(), count));
  double sum = 0;
  for (size_t i = 0; i < count; ++i) {
    if (!std::isfinite(weights[i]) || weights[i] < 0)
      throw InputError(fmt::format("{}: weight {} of camera {} is not a finite number >= 0", who, weights[i], i));
    sum += weights[i];
  }
  if (!(sum > 0)) throw InputError(fmt::format("{}: the weights are all zero", who));
  std::vector<double> w(weights);
  for (double& x : w) x /= sum;
  return w;
}

// Same units (and method, unless any_method) everywhere; frame and timestamp of the newest input.
LightList output_header(const std::vector<LightList>& cameras, const char* who, bool any_method = false) {
  LightList out;
  out.method = cameras.front().method;
  out.units = cameras.front().units;
  out.frame = cameras.front().frame;
  out.timestamp = cameras.front().timestamp;
  for (size_t i = 1; i < cameras.size(); ++i) {
    const LightList& c = cameras[i];
    if (c.method != out.method && !any_method)
      throw InputError(fmt::format("{}: camera {} has method '{}', camera 0 '{}': lists of different methods "
                                   "cannot be merged", who, i, c.method, out.method));
    if (c.units != out.units)
      throw InputError(fmt::format("{}: camera {} is in {} units, camera 0 in {}", who, i, to_string(c.units),
                                   to_string(out.units)));
    out.frame = std::max(out.frame, c.frame);
    out.timestamp = std::max(out.timestamp, c.timestamp);
  }
  return out;
}

bool finite(const Light& l) {
  return std::isfinite(l.direction.x) && std::isfinite(l.direction.y) && std::isfinite(l.direction.z) &&
         std::isfinite(l.rgb[0]) && std::isfinite(l.rgb[1]) && std::isfinite(l.rgb[2]) &&
         std::isfinite(l.solid_angle);
}

// ---- Q2-tree -----------------------------------------------------------------------

struct Node {
  int level = 0;
  uint64_t ipix = 0;
};

uint64_t nuniq(int level, uint64_t ipix) { return (uint64_t(4) << (2 * level)) + ipix; }

std::optional<Node> decode_nuniq(uint64_t id) {
  if (id < 4) return std::nullopt;
  const int level = (int(std::bit_width(id >> 2)) - 1) / 2;
  if (level > kMaxLevel) return std::nullopt;
  const uint64_t ipix = id - (uint64_t(4) << (2 * level));
  if (ipix >= (uint64_t(12) << (2 * level))) return std::nullopt;
  return Node{level, ipix};
}

Vec3 quad_centre(int level, uint64_t ipix) {
  return healpix_direction(int64_t(1) << level, int64_t(ipix));
}

struct Value {
  std::array<double, 3> rgb{0, 0, 0};
  Vec3 c;  // luminance-weighted direction sum
};

// Whether the list's ids are NUNIQ nodes whose cells partition the sphere.
bool is_q2_partition(const LightList& list) {
  std::vector<Node> nodes;
  nodes.reserve(list.lights.size());
  int finest = 0;
  for (const Light& l : list.lights) {
    const auto node = decode_nuniq(l.id);
    if (!node) return false;
    nodes.push_back(*node);
    finest = std::max(finest, node->level);
  }
  std::vector<std::pair<uint64_t, uint64_t>> ranges;
  ranges.reserve(nodes.size());
  for (const Node& n : nodes) {
    const int shift = 2 * (finest - n.level);
    ranges.emplace_back(n.ipix << shift, (n.ipix + 1) << shift);
  }
  std::sort(ranges.begin(), ranges.end());
  uint64_t at = 0;
  for (const auto& [b, e] : ranges) {
    if (b != at) return false;
    at = e;
  }
  return at == (uint64_t(12) << (2 * finest));
}

// One camera's tree as its leaves, sorted by their range at the common finest level.
class CameraTree {
 public:
  CameraTree(const LightList& list, size_t index, int finest) : finest_(finest) {
    struct Leaf {
      uint64_t start, end;
      int level;
      const Light* light;
    };
    std::vector<Leaf> leaves;
    leaves.reserve(list.lights.size());
    for (const Light& l : list.lights) {
      const auto node = decode_nuniq(l.id);
      if (!node) throw InputError(fmt::format("merge_q2trees: camera {}: id {} is not a HEALPix NUNIQ node", index, l.id));
      if (!finite(l)) throw InputError(fmt::format("merge_q2trees: camera {}: light {} is not finite", index, l.id));
      const int shift = 2 * (finest - node->level);
      leaves.push_back({node->ipix << shift, (node->ipix + 1) << shift, node->level, &l});
    }
    std::sort(leaves.begin(), leaves.end(), [](const Leaf& a, const Leaf& b) { return a.start < b.start; });
    uint64_t at = 0;
    for (const Leaf& leaf : leaves) {
      if (leaf.start != at)
        throw InputError(fmt::format("merge_q2trees: camera {}: its leaves do not partition the sphere "
                                     "(overlap or gap at node {})", index, leaf.light->id));
      at = leaf.end;
    }
    if (at != (uint64_t(12) << (2 * finest)))
      throw InputError(fmt::format("merge_q2trees: camera {}: its leaves do not cover the sphere", index));
    prefix_.resize(leaves.size() + 1);
    for (size_t k = 0; k < leaves.size(); ++k) {
      const Light& l = *leaves[k].light;
      start_.push_back(leaves[k].start);
      end_.push_back(leaves[k].end);
      level_.push_back(leaves[k].level);
      Value v = prefix_[k];
      for (int c = 0; c < 3; ++c) v.rgb[c] += l.rgb[c];
      const double len = length(l.direction);
      if (len > 0) v.c = v.c + (l.luminance() / len) * l.direction;
      prefix_[k + 1] = v;
      ids_.push_back(l.id);
    }
  }

  const std::vector<uint64_t>& ids() const { return ids_; }

  // This camera's value at a node: exact if its tree has the node, else the node's
  // share of the enclosing leaf (uniform inside the leaf), located at the node's centre.
  Value value(int level, uint64_t ipix) const {
    const int shift = 2 * (finest_ - level);
    const uint64_t b = ipix << shift, e = (ipix + 1) << shift;
    const size_t k = size_t(std::upper_bound(start_.begin(), start_.end(), b) - start_.begin()) - 1;
    Value v;
    if (start_[k] == b && level_[k] >= level) {
      const size_t k2 = size_t(std::lower_bound(end_.begin(), end_.end(), e) - end_.begin());
      for (int c = 0; c < 3; ++c) v.rgb[c] = prefix_[k2 + 1].rgb[c] - prefix_[k].rgb[c];
      v.c = prefix_[k2 + 1].c - prefix_[k].c;
      return v;
    }
    const double share = std::ldexp(1.0, -2 * (level - level_[k]));
    for (int c = 0; c < 3; ++c) v.rgb[c] = share * (prefix_[k + 1].rgb[c] - prefix_[k].rgb[c]);
    v.c = luminance(v.rgb.data()) * quad_centre(level, ipix);
    return v;
  }

 private:
  int finest_;
  std::vector<uint64_t> start_, end_, ids_;
  std::vector<int> level_;
  std::vector<Value> prefix_;
};

}  // namespace

// ---- index-wise --------------------------------------------------------------------

LightList merge_by_index(const std::vector<LightList>& cameras, const std::vector<double>& weights) {
  const auto w = normalised_weights(cameras.size(), weights, "merge_by_index");
  LightList out = output_header(cameras, "merge_by_index");
  if (out.method != "pharr" && out.method != "hemigon")
    throw InputError(fmt::format("merge_by_index: merges pharr or hemigon lists (ids = Halton indices), not '{}'",
                                 out.method));
  struct Sum {
    double weight = 0, heaviest = -1;
    Vec3 d, heaviest_d;
    std::array<double, 3> rgb{0, 0, 0};
    double solid_angle = 0;
  };
  std::map<uint64_t, Sum> sums;
  for (size_t i = 0; i < cameras.size(); ++i) {
    std::unordered_set<uint64_t> seen;
    for (const Light& l : cameras[i].lights) {
      if (!seen.insert(l.id).second)
        throw InputError(fmt::format("merge_by_index: camera {} has light id {} twice", i, l.id));
      if (!finite(l)) throw InputError(fmt::format("merge_by_index: camera {}: light {} is not finite", i, l.id));
      Sum& s = sums[l.id];
      s.weight += w[i];
      s.d = s.d + w[i] * l.direction;
      for (int c = 0; c < 3; ++c) s.rgb[c] += w[i] * l.rgb[c];
      s.solid_angle += w[i] * l.solid_angle;
      if (w[i] > s.heaviest) s.heaviest = w[i], s.heaviest_d = l.direction;
    }
  }
  out.lights.reserve(sums.size());
  for (const auto& [id, s] : sums) {
    if (!(s.weight > 0)) continue;  // only in inputs of weight 0
    Light l;
    l.id = id;
    const double len = length(s.d);
    l.direction = len > 1e-12 * s.weight ? (1.0 / len) * s.d : normalize(s.heaviest_d);
    for (int c = 0; c < 3; ++c) l.rgb[c] = s.rgb[c] / s.weight;
    l.solid_angle = s.solid_angle / s.weight;
    out.lights.push_back(l);
  }
  return out;
}

std::vector<double> position_weights(const std::vector<Vec3>& camera_positions, Vec3 target, double power) {
  if (camera_positions.empty()) throw InputError("position_weights: no camera positions");
  if (!std::isfinite(power) || power < 0)
    throw InputError(fmt::format("position_weights: power must be finite and >= 0, got {}", power));
  const auto bad = [](Vec3 p) { return !std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z); };
  if (bad(target)) throw InputError("position_weights: the target position is not finite");
  std::vector<double> dist;
  double max_d = 0;
  for (size_t i = 0; i < camera_positions.size(); ++i) {
    if (bad(camera_positions[i]))
      throw InputError(fmt::format("position_weights: position of camera {} is not finite", i));
    dist.push_back(length(camera_positions[i] - target));
    max_d = std::max(max_d, dist.back());
  }
  std::vector<double> w(dist.size(), 0.0);
  size_t at_target = 0;
  for (size_t i = 0; i < dist.size(); ++i)
    if (dist[i] <= 1e-12 * max_d) ++at_target;
  if (at_target > 0) {
    for (size_t i = 0; i < dist.size(); ++i)
      if (dist[i] <= 1e-12 * max_d) w[i] = 1.0 / double(at_target);
    return w;
  }
  double sum = 0;
  for (size_t i = 0; i < dist.size(); ++i) sum += (w[i] = std::pow(dist[i] / max_d, -power));
  for (double& x : w) x /= sum;
  return w;
}

// ---- Q2-tree merge (Algorithm 2) ---------------------------------------------------

LightList merge_q2trees(const std::vector<LightList>& cameras, const std::vector<double>& weights, int n,
                        const Q2MergeOptions& options) {
  const auto w = normalised_weights(cameras.size(), weights, "merge_q2trees");
  LightList out = output_header(cameras, "merge_q2trees");
  if (out.method != "q2tree")
    throw InputError(fmt::format("merge_q2trees: merges q2tree lists (ids = NUNIQ nodes), not '{}'", out.method));
  if (n < 12)
    throw InputError(fmt::format("merge_q2trees: needs n >= 12 lights (one per HEALPix base quad), got {}", n));
  if (!std::isfinite(options.luminance_exponent) || !std::isfinite(options.solid_angle_exponent))
    throw InputError("merge_q2trees: importance exponents must be finite");

  // Step 1: reconstruct each tree (at the deepest level any input reaches).
  int finest = 0;
  for (size_t i = 0; i < cameras.size(); ++i)
    for (const Light& l : cameras[i].lights) {
      const auto node = decode_nuniq(l.id);
      if (!node) throw InputError(fmt::format("merge_q2trees: camera {}: id {} is not a HEALPix NUNIQ node", i, l.id));
      finest = std::max(finest, node->level);
    }
  std::vector<CameraTree> trees;
  trees.reserve(cameras.size());
  for (size_t i = 0; i < cameras.size(); ++i) trees.emplace_back(cameras[i], i, finest);

  // Step 2: the merged tree: every ancestor of any input leaf is interior.
  std::unordered_set<uint64_t> interior;
  for (const CameraTree& t : trees)
    for (uint64_t id : t.ids()) {
      Node node = *decode_nuniq(id);
      while (node.level > 0) {
        node = {node.level - 1, node.ipix >> 2};
        if (!interior.insert(nuniq(node.level, node.ipix)).second) break;
      }
    }
  const auto merged_value = [&](int level, uint64_t ipix) {
    Value m;
    for (size_t i = 0; i < trees.size(); ++i) {
      if (w[i] == 0) continue;
      const Value v = trees[i].value(level, ipix);
      for (int c = 0; c < 3; ++c) m.rgb[c] += w[i] * v.rgb[c];
      m.c = m.c + w[i] * v.c;
    }
    return m;
  };
  // Step 3 is implied: every camera's values are consistent sums (header).
  // Step 4: importance of the interior nodes.
  struct Ranked {
    double p;
    uint64_t id;
  };
  // Pops the lowest rank first: smaller importance, on ties the larger NUNIQ.
  const auto ranks_higher = [](const Ranked& a, const Ranked& b) { return a.p > b.p || (a.p == b.p && a.id < b.id); };
  std::priority_queue<Ranked, std::vector<Ranked>, decltype(ranks_higher)> mergeable(ranks_higher);
  const auto importance = [&](const Node& node) {
    const Value v = merged_value(node.level, node.ipix);
    const double power = std::max(0.0, luminance(v.rgb.data()));
    const double dw = M_PI / (3.0 * std::ldexp(1.0, 2 * node.level));
    const double p = std::pow(power, options.luminance_exponent) * std::pow(dw, options.solid_angle_exponent);
    return std::isnan(p) ? -HUGE_VAL : p;
  };
  const auto children_are_leaves = [&](const Node& node) {
    for (uint64_t k = 0; k < 4; ++k)
      if (interior.count(nuniq(node.level + 1, 4 * node.ipix + k))) return false;
    return true;
  };
  for (uint64_t id : interior) {
    const Node node = *decode_nuniq(id);
    if (children_are_leaves(node)) mergeable.push({importance(node), id});
  }
  // Step 5: collapse the least important mergeable node until 12 + 3 S <= n.
  const size_t target = size_t(n - 12) / 3;
  while (interior.size() > target) {
    const Ranked r = mergeable.top();
    mergeable.pop();
    interior.erase(r.id);
    const Node node = *decode_nuniq(r.id);
    if (node.level > 0) {
      const Node parent{node.level - 1, node.ipix >> 2};
      if (children_are_leaves(parent)) mergeable.push({importance(parent), nuniq(parent.level, parent.ipix)});
    }
  }
  // Step 6: one light per leaf.
  std::vector<Node> leaves;
  for (uint64_t b = 0; b < 12; ++b)
    if (!interior.count(nuniq(0, b))) leaves.push_back({0, b});
  for (uint64_t id : interior) {
    const Node node = *decode_nuniq(id);
    for (uint64_t k = 0; k < 4; ++k)
      if (!interior.count(nuniq(node.level + 1, 4 * node.ipix + k))) leaves.push_back({node.level + 1, 4 * node.ipix + k});
  }
  out.lights.reserve(leaves.size());
  for (const Node& node : leaves) {
    const Value v = merged_value(node.level, node.ipix);
    Light l;
    l.id = nuniq(node.level, node.ipix);
    l.rgb = v.rgb;
    l.solid_angle = M_PI / (3.0 * std::ldexp(1.0, 2 * node.level));
    const double power = luminance(v.rgb.data());
    const double len = length(v.c);
    l.direction = (power > 0 && len > 1e-12 * power) ? (1.0 / len) * v.c : quad_centre(node.level, node.ipix);
    out.lights.push_back(l);
  }
  std::sort(out.lights.begin(), out.lights.end(), [](const Light& a, const Light& b) { return a.id < b.id; });
  return out;
}

// ---- by direction ---------------------------------------------------------------------

namespace {

constexpr int kPointLevel = 12;  // HEALPix nside 4096: pixels of 0.014 deg

// The union of the cameras' weighted lights, summed per level-12 pixel.
struct Point {
  uint64_t pixel = 0;
  std::array<double, 3> rgb{0, 0, 0};
  Vec3 c;  // sum of luminance * direction
};

// Leaves of the tree over points[begin, end) inside cell (level, ipix): a cell splits
// while it holds more than one pixel's points.
void point_leaves(const std::vector<Point>& points, size_t begin, size_t end, int level, uint64_t ipix,
                  std::vector<Light>& out) {
  if (end - begin > 1 && level < kPointLevel) {
    const int shift = 2 * (kPointLevel - level - 1);
    size_t at = begin;
    for (uint64_t k = 0; k < 4; ++k) {
      const uint64_t child = 4 * ipix + k, child_end = (child + 1) << shift;
      const size_t stop = size_t(std::lower_bound(points.begin() + long(at), points.begin() + long(end), child_end,
                                                  [](const Point& p, uint64_t v) { return p.pixel < v; }) -
                                 points.begin());
      point_leaves(points, at, stop, level + 1, child, out);
      at = stop;
    }
    return;
  }
  Light l;
  l.id = nuniq(level, ipix);
  l.solid_angle = M_PI / (3.0 * std::ldexp(1.0, 2 * level));
  Vec3 c;
  for (size_t k = begin; k < end; ++k) {
    for (int ch = 0; ch < 3; ++ch) l.rgb[ch] += points[k].rgb[ch];
    c = c + points[k].c;
  }
  const double len = length(c);
  l.direction = len > 0 ? (1.0 / len) * c : quad_centre(level, ipix);
  out.push_back(l);
}

}  // namespace

LightList merge_by_direction(const std::vector<LightList>& cameras, const std::vector<double>& weights, int n,
                             const Q2MergeOptions& options) {
  const auto w = normalised_weights(cameras.size(), weights, "merge_by_direction");
  LightList tree = output_header(cameras, "merge_by_direction", true);
  tree.method = "q2tree";
  std::vector<Point> points;
  for (size_t i = 0; i < cameras.size(); ++i) {
    if (w[i] == 0) continue;
    for (const Light& l : cameras[i].lights) {
      if (!finite(l)) throw InputError(fmt::format("merge_by_direction: camera {}: light {} is not finite", i, l.id));
      const double len = length(l.direction);
      if (!(len > 0)) throw InputError(fmt::format("merge_by_direction: camera {}: light {} has no direction", i, l.id));
      const Vec3 d = (1.0 / len) * l.direction;
      Point p;
      p.pixel = uint64_t(healpix_pixel(int64_t(1) << kPointLevel, d));
      for (int c = 0; c < 3; ++c) p.rgb[c] = w[i] * l.rgb[c];
      p.c = luminance(p.rgb.data()) * d;
      points.push_back(p);
    }
  }
  std::sort(points.begin(), points.end(), [](const Point& a, const Point& b) { return a.pixel < b.pixel; });
  // Points in one pixel are one point (their sum at their centroid).
  std::vector<Point> merged;
  for (const Point& p : points) {
    if (merged.empty() || merged.back().pixel != p.pixel) {
      merged.push_back(p);
      continue;
    }
    for (int c = 0; c < 3; ++c) merged.back().rgb[c] += p.rgb[c];
    merged.back().c = merged.back().c + p.c;
  }
  size_t at = 0;
  for (uint64_t b = 0; b < 12; ++b) {
    const uint64_t end_pixel = (b + 1) << (2 * kPointLevel);
    const size_t stop = size_t(std::lower_bound(merged.begin() + long(at), merged.end(), end_pixel,
                                                [](const Point& p, uint64_t v) { return p.pixel < v; }) -
                               merged.begin());
    point_leaves(merged, at, stop, 0, b, tree.lights);
    at = stop;
  }
  return merge_q2trees({tree}, {1.0}, n, options);
}

const char* to_string(MergeMode mode) {
  switch (mode) {
    case MergeMode::Index: return "index";
    case MergeMode::Q2Tree: return "q2tree";
    case MergeMode::Direction: return "direction";
  }
  return "direction";
}

MergeMode merge_mode(const std::vector<LightList>& cameras) {
  if (cameras.empty()) return MergeMode::Direction;
  const std::string& method = cameras.front().method;
  for (const LightList& c : cameras)
    if (c.method != method) return MergeMode::Direction;
  if (method == "pharr" || method == "hemigon") {
    for (const LightList& c : cameras) {
      std::unordered_set<uint64_t> seen;
      for (const Light& l : c.lights)
        if (!seen.insert(l.id).second) return MergeMode::Direction;
    }
    return MergeMode::Index;
  }
  if (method == "q2tree") {
    for (const LightList& c : cameras)
      if (!is_q2_partition(c)) return MergeMode::Direction;
    return MergeMode::Q2Tree;
  }
  return MergeMode::Direction;
}

std::optional<MergeProblem> merge_problem(const LightList& list) {
  const size_t max_lights = size_t(limits().max_lights);
  constexpr double kMaxTotal = 1e300;
  if (list.lights.empty()) return MergeProblem{"empty", "the list has no lights"};
  if (list.lights.size() > max_lights)
    return MergeProblem{"too_many", fmt::format("{} lights (at most {})", list.lights.size(), max_lights)};
  std::array<double, 3> total{0, 0, 0};
  for (size_t k = 0; k < list.lights.size(); ++k) {
    const Light& l = list.lights[k];
    if (!finite(l)) return MergeProblem{"not_finite", fmt::format("light {} (id {}) is not finite", k, l.id)};
    if (l.rgb[0] < 0 || l.rgb[1] < 0 || l.rgb[2] < 0 || l.solid_angle < 0)
      return MergeProblem{"negative", fmt::format("light {} (id {}) has a negative rgb or solid angle", k, l.id)};
    const double len = length(l.direction);
    if (!(std::fabs(len - 1) <= 1e-6))
      return MergeProblem{"not_unit", fmt::format("light {} (id {}) has a direction of length {}", k, l.id, len)};
    for (int c = 0; c < 3; ++c) total[c] += l.rgb[c];
  }
  for (int c = 0; c < 3; ++c)
    if (!(total[c] <= kMaxTotal))
      return MergeProblem{"too_bright", fmt::format("total power {} in channel {} (at most {:g})", total[c], c, kMaxTotal)};
  return std::nullopt;
}

LightList merge_light_lists(const std::vector<LightList>& cameras, const std::vector<double>& weights, int n,
                            const Q2MergeOptions& options) {
  if (cameras.empty()) throw InputError("merge: no cameras to merge");
  output_header(cameras, "merge", true);  // one unit everywhere
  switch (merge_mode(cameras)) {
    case MergeMode::Index: return merge_by_index(cameras, weights);
    case MergeMode::Q2Tree: return merge_q2trees(cameras, weights, n, options);
    case MergeMode::Direction: break;
  }
  return merge_by_direction(cameras, weights, n, options);
}

// ---- robustness ------------------------------------------------------------------------

namespace {

bool usable_output(const LightList& list) {
  for (const Light& l : list.lights)
    if (!finite(l) || !(std::fabs(length(l.direction) - 1) <= 1e-6)) return false;
  return true;
}

}  // namespace

LightList merge_available(const std::vector<MergeInput>& inputs, double now_s, double timeout_s, MergeState& state,
                          const MergeAvailableOptions& options) {
  if (!std::isfinite(timeout_s) || timeout_s < 0)
    throw InputError(fmt::format("merge_available: timeout must be finite and >= 0, got {}", timeout_s));
  if (!options.weights.empty() && options.weights.size() != inputs.size())
    throw InputError(fmt::format("merge_available: {} weights for {} inputs", options.weights.size(), inputs.size()));
  std::vector<LightList> alive;
  std::vector<double> weights;
  std::vector<std::string> used, dropped;
  state.skipped.clear();
  std::optional<Units> units;
  for (size_t i = 0; i < inputs.size(); ++i) {
    const MergeInput& in = inputs[i];
    const bool live = in.latest.has_value() && std::isfinite(in.last_seen_s) && now_s - in.last_seen_s <= timeout_s;
    if (!live) {
      dropped.push_back(in.name);
      continue;
    }
    if (auto problem = merge_problem(*in.latest)) {
      state.skipped.push_back({in.name, problem->code, problem->detail});
      continue;
    }
    if (units && *units != in.latest->units) {
      state.skipped.push_back({in.name, "units", fmt::format("in {} units, the inputs before it in {}",
                                                             to_string(in.latest->units), to_string(*units))});
      continue;
    }
    units = in.latest->units;
    alive.push_back(*in.latest);
    weights.push_back(options.weights.empty() ? 1.0 : options.weights[i]);
    used.push_back(in.name);
  }
  double weight_sum = 0;
  for (double x : weights) weight_sum += x;
  // Nothing to merge, or a merge that failed: the last output again, flagged.
  const auto repeat_last = [&](std::string error) {
    state.stale = true;
    state.error = std::move(error);
    state.used.clear();
    state.dropped = std::move(dropped);
    for (const std::string& name : used) state.dropped.push_back(name);
    return state.last_output ? *state.last_output : LightList{};
  };
  if (alive.empty() || !(weight_sum > 0)) return repeat_last("");
  LightList out;
  try {
    out = merge_light_lists(alive, weights, options.n, options.q2);
  } catch (const InputError& e) {
    return repeat_last(e.what());
  }
  if (!usable_output(out)) return repeat_last("the merged list is not finite");
  state.mode = merge_mode(alive);
  state.last_output = out;
  state.stale = false;
  state.error.clear();
  state.used = std::move(used);
  state.dropped = std::move(dropped);
  return out;
}

}  // namespace lp
