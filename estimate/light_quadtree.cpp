#include "estimate/light_quadtree.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <sstream>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/json_file.h"

namespace lp {

namespace {

// Elevation of a sector's centroid: mean z over a hemisphere is 1/2; the mean horizontal
// component over a 120 deg wedge is (pi/4) * sin(60 deg) / (pi/3) = 3 sqrt(3) / 8.
const double kSectorElevation = std::atan2(0.5, 3.0 * std::sqrt(3.0) / 8.0);

bool finite_position(double x, double y) { return std::isfinite(x) && std::isfinite(y); }

void add_to(SectorSample& s, const LightReading& r, double max_weight, int64_t frame) {
  s.weight = max_weight > 0 ? std::min(s.weight + 1, max_weight) : s.weight + 1;
  const double a = 1.0 / s.weight;  // running mean; with a cap, an exponential average
  const auto rad = r.radiance();
  for (int c = 0; c < 3; ++c) s.radiance[c] += a * (rad[c] - s.radiance[c]);
  s.luminance += a * (r.luminance - s.luminance);
  if (r.cct_k > 0 && std::isfinite(r.cct_k)) {
    s.mired_weight = max_weight > 0 ? std::min(s.mired_weight + 1, max_weight) : s.mired_weight + 1;
    s.mired += (1e6 / r.cct_k - s.mired) / s.mired_weight;
  }
  s.last_frame = frame;
}

}  // namespace

int bipyramid_sector(Vec3 d) {
  double phi = std::atan2(d.y, d.x) + M_PI / 3;  // wedge k spans [120k - 60, 120k + 60) deg
  if (phi < 0) phi += 2 * M_PI;
  const int wedge = int(phi / (2 * M_PI / 3)) % 3;
  return d.z >= 0 ? wedge : 3 + wedge;
}

Vec3 bipyramid_direction(int sector) {
  const double phi = (sector % 3) * 2 * M_PI / 3;
  const double e = sector < 3 ? kSectorElevation : -kSectorElevation;
  return {std::cos(e) * std::cos(phi), std::cos(e) * std::sin(phi), std::sin(e)};
}

bool QuadNode::informed() const {
  for (const auto& s : sectors)
    if (s.informed()) return true;
  return false;
}

bool QuadNode::contains(double x, double y) const {
  const double h = size / 2;
  return x >= cx - h && x <= cx + h && y >= cy - h && y <= cy + h;
}

LightQuadtree::LightQuadtree(const QuadtreeOptions& o) : options_(o) {
  if (!finite_position(o.origin_x, o.origin_y)) throw InputError("quadtree: the origin must be finite");
  if (!(o.root_size > 0) || !std::isfinite(o.root_size))
    throw InputError(fmt::format("--root-size must be positive, got {}", o.root_size));
  if (!(o.min_size > 0) || o.min_size > o.root_size)
    throw InputError(fmt::format("--min-size must be in (0, root size {}], got {}", o.root_size, o.min_size));
  if (!(o.max_weight >= 0)) throw InputError(fmt::format("--max-weight must be >= 0, got {}", o.max_weight));
  QuadNode root;
  root.cx = o.origin_x;
  root.cy = o.origin_y;
  root.size = o.root_size;
  nodes_.push_back(root);
}

void LightQuadtree::split(int index) {
  const QuadNode parent = nodes_[index];
  const double q = parent.size / 4;
  for (int k = 0; k < 4; ++k) {
    QuadNode child;
    child.cx = parent.cx + (k & 1 ? q : -q);
    child.cy = parent.cy + (k & 2 ? q : -q);
    child.size = parent.size / 2;
    child.depth = parent.depth + 1;
    child.parent = index;
    nodes_[index].children[k] = int(nodes_.size());
    nodes_.push_back(child);
  }
}

int LightQuadtree::leaf_at(double x, double y) const {
  if (!finite_position(x, y) || !nodes_[0].contains(x, y)) return -1;
  int i = 0;
  while (!nodes_[i].leaf()) {
    const QuadNode& n = nodes_[i];
    i = n.children[(x >= n.cx ? 1 : 0) + (y >= n.cy ? 2 : 0)];
  }
  return i;
}

int LightQuadtree::update(double x, double y, Vec3 view, const LightReading& reading, int64_t frame) {
  if (!(length(view) > 0) || !std::isfinite(length(view)))
    throw InputError(fmt::format("frame {}: the view direction must be finite and non-zero", frame));
  ++updates_;
  int i = leaf_at(x, y);
  if (i < 0) {
    ++outside_;
    return -1;
  }
  // Subdivide where there is already data, down to min_size (children of side size / 2).
  if (nodes_[i].informed() && nodes_[i].size / 2 >= options_.min_size * (1 - 1e-9)) {
    split(i);
    i = leaf_at(x, y);
  }
  const int sector = bipyramid_sector(view);
  for (int n = i; n >= 0; n = nodes_[n].parent) add_to(nodes_[n].sectors[sector], reading, options_.max_weight, frame);
  return i;
}

int LightQuadtree::max_depth() const {
  int d = 0;
  for (const auto& n : nodes_) d = std::max(d, n.depth);
  return d;
}

namespace {

// Fill never-observed sectors from the observed ones, same hemisphere first.
void fill_missing(std::array<SectorLookup, kBipyramidSectors>& out) {
  auto fill = [&](int s, bool same_hemisphere) {
    SectorSample mean;
    int count = 0;
    for (int o = 0; o < kBipyramidSectors; ++o) {
      if (out[o].node < 0 || (same_hemisphere && (o < 3) != (s < 3))) continue;
      for (int c = 0; c < 3; ++c) mean.radiance[c] += out[o].sample.radiance[c];
      mean.luminance += out[o].sample.luminance;
      mean.mired += out[o].sample.mired;
      mean.mired_weight += out[o].sample.mired_weight > 0 ? 1 : 0;
      ++count;
    }
    if (count == 0) return false;
    for (double& c : mean.radiance) c /= count;
    mean.luminance /= count;
    mean.mired = mean.mired_weight > 0 ? mean.mired / mean.mired_weight : 0;
    mean.weight = 0;
    out[s] = {mean, -1, -1, true};
    return true;
  };
  std::array<bool, kBipyramidSectors> missing{};
  for (int s = 0; s < kBipyramidSectors; ++s) missing[s] = out[s].node < 0;
  for (int s = 0; s < kBipyramidSectors; ++s)
    if (missing[s] && !fill(s, true)) fill(s, false);
}

}  // namespace

std::vector<int> LightQuadtree::path_to(double x, double y, int max_depth) const {
  // The path from the root down to the leaf containing (x, y) (just the root outside it).
  std::vector<int> path{0};
  if (finite_position(x, y) && nodes_[0].contains(x, y)) {
    while (!nodes_[path.back()].leaf() && (max_depth < 0 || nodes_[path.back()].depth < max_depth)) {
      const QuadNode& n = nodes_[path.back()];
      path.push_back(n.children[(x >= n.cx ? 1 : 0) + (y >= n.cy ? 2 : 0)]);
    }
  }
  return path;
}

std::array<SectorLookup, kBipyramidSectors> LightQuadtree::lookup(double x, double y, int max_depth,
                                                                   double min_weight) const {
  const std::vector<int> path = path_to(x, y, max_depth);
  std::array<SectorLookup, kBipyramidSectors> out;
  for (int s = 0; s < kBipyramidSectors; ++s) {
    for (auto it = path.rbegin(); it != path.rend(); ++it) {
      const SectorSample& sample = nodes_[*it].sectors[s];
      if (sample.informed() && (sample.weight >= min_weight || *it == 0)) {
        out[s] = {sample, *it, nodes_[*it].depth, false};
        break;
      }
    }
  }
  fill_missing(out);
  return out;
}

std::array<SectorLookup, kBipyramidSectors> LightQuadtree::lookup_shrunk(double x, double y,
                                                                          double prior_weight) const {
  const std::vector<int> path = path_to(x, y, -1);
  std::array<SectorLookup, kBipyramidSectors> out;
  for (int s = 0; s < kBipyramidSectors; ++s) {
    if (!nodes_[0].sectors[s].informed()) continue;
    SectorSample est = nodes_[0].sectors[s];
    int node = 0;
    for (size_t k = 1; k < path.size(); ++k) {
      const SectorSample& m = nodes_[path[k]].sectors[s];
      if (!m.informed()) break;  // children of an uninformed node are uninformed too
      const double a = m.weight / (m.weight + prior_weight);
      for (int c = 0; c < 3; ++c) est.radiance[c] += a * (m.radiance[c] - est.radiance[c]);
      est.luminance += a * (m.luminance - est.luminance);
      if (m.mired_weight > 0) est.mired += a * (m.mired - est.mired);
      est.weight = m.weight;
      est.last_frame = m.last_frame;
      node = path[k];
    }
    out[s] = {est, node, nodes_[node].depth, false};
  }
  fill_missing(out);
  return out;
}

namespace {

LightList lights_of(const std::array<SectorLookup, kBipyramidSectors>& look) {
  LightList list;
  list.method = "metadata";
  list.units = Units::Radiance;
  for (int s = 0; s < kBipyramidSectors; ++s) {
    if (look[s].node < 0 && !look[s].filled) continue;
    Light l;
    l.id = uint64_t(s);
    l.direction = bipyramid_direction(s);
    for (int c = 0; c < 3; ++c) l.rgb[c] = look[s].sample.radiance[c] * kBipyramidSolidAngle;
    l.solid_angle = kBipyramidSolidAngle;
    list.lights.push_back(l);
  }
  return list;
}

}  // namespace

LightList LightQuadtree::lights_at(double x, double y, int max_depth, double min_weight) const {
  return lights_of(lookup(x, y, max_depth, min_weight));
}

LightList LightQuadtree::lights_shrunk(double x, double y, double prior_weight) const {
  return lights_of(lookup_shrunk(x, y, prior_weight));
}

std::string LightQuadtree::to_json() const {
  nlohmann::json nodes = nlohmann::json::array();
  for (size_t i = 0; i < nodes_.size(); ++i) {
    const QuadNode& n = nodes_[i];
    nlohmann::json sectors = nlohmann::json::array();
    for (const auto& s : n.sectors)
      sectors.push_back({{"weight", s.weight},
                         {"radiance", s.radiance},
                         {"luminance", s.luminance},
                         {"cct", s.mired > 0 ? 1e6 / s.mired : 0.0},
                         {"mired", s.mired},
                         {"mired_weight", s.mired_weight},
                         {"last_frame", s.last_frame}});
    nodes.push_back({{"id", i},
                     {"parent", n.parent},
                     {"center", {n.cx, n.cy}},
                     {"size", n.size},
                     {"depth", n.depth},
                     {"children", n.children},
                     {"sectors", sectors}});
  }
  nlohmann::json dirs = nlohmann::json::array();
  for (int s = 0; s < kBipyramidSectors; ++s) {
    const Vec3 d = bipyramid_direction(s);
    dirs.push_back({d.x, d.y, d.z});
  }
  nlohmann::json j{{"format", "lightprobe.metadata-model/1"},
                   {"units", "radiance"},
                   {"frame_convention", "z-up"},
                   {"origin", {options_.origin_x, options_.origin_y}},
                   {"root_size", options_.root_size},
                   {"min_size", options_.min_size},
                   {"max_weight", options_.max_weight},
                   {"updates", updates_},
                   {"outside_updates", outside_},
                   {"sector_directions", dirs},
                   {"nodes", nodes}};
  return j.dump(1) + "\n";
}

LightQuadtree LightQuadtree::from_json(const std::string& text, const std::string& source) {
  const nlohmann::json j = parse_json_text(text, source);
  check_json_format(j, source, "lightprobe.metadata-model/1");
  try {
    QuadtreeOptions o;
    o.origin_x = j.at("origin").at(0).get<double>();
    o.origin_y = j.at("origin").at(1).get<double>();
    o.root_size = j.at("root_size").get<double>();
    o.min_size = j.at("min_size").get<double>();
    o.max_weight = j.value("max_weight", 0.0);
    LightQuadtree t(o);
    t.updates_ = j.value("updates", int64_t(0));
    t.outside_ = j.value("outside_updates", int64_t(0));
    t.nodes_.clear();
    for (const auto& jn : j.at("nodes")) {
      QuadNode n;
      n.cx = jn.at("center").at(0).get<double>();
      n.cy = jn.at("center").at(1).get<double>();
      n.size = jn.at("size").get<double>();
      n.depth = jn.at("depth").get<int>();
      n.parent = jn.at("parent").get<int>();
      n.children = jn.at("children").get<std::array<int, 4>>();
      const auto& js = jn.at("sectors");
      if (js.size() != kBipyramidSectors) throw InputError(fmt::format("{}: a node needs 6 sectors", source));
      for (int s = 0; s < kBipyramidSectors; ++s) {
        SectorSample& ss = n.sectors[s];
        ss.weight = js[s].at("weight").get<double>();
        ss.radiance = js[s].at("radiance").get<std::array<double, 3>>();
        ss.luminance = js[s].at("luminance").get<double>();
        ss.mired = js[s].value("mired", 0.0);
        ss.mired_weight = js[s].value("mired_weight", 0.0);
        ss.last_frame = js[s].value("last_frame", int64_t(-1));
      }
      t.nodes_.push_back(n);
    }
    // Structure check: every link in range, parents and children agree.
    const int count = int(t.nodes_.size());
    if (count == 0) throw InputError(fmt::format("{}: no nodes", source));
    for (int i = 0; i < count; ++i) {
      const QuadNode& n = t.nodes_[i];
      if ((i == 0) != (n.parent < 0) || n.parent >= count)
        throw InputError(fmt::format("{}: node {} has a bad parent", source, i));
      for (int c : n.children)
        if (c >= count || (c >= 0 && t.nodes_[c].parent != i) || (c < 0) != (n.children[0] < 0))
          throw InputError(fmt::format("{}: node {} has bad children", source, i));
    }
    return t;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(json_field_problem(source, e));
  }
}

void save_model(const std::string& path, const LightQuadtree& tree) { write_file_atomically(path, tree.to_json()); }

LightQuadtree load_model(const std::string& path) {
  return LightQuadtree::from_json(read_text_file(path, "the model"), path);
}

}  // namespace lp
