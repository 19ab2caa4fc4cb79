// The spatial lighting model of seed 003 (GRAPP 2024 fragment, section 3): a 2D quadtree
// over the floor plane whose nodes each hold six directional samples on a triangular
// bipyramid, fed frame by frame from camera metadata (estimate/exposure_metering.h).
//
// Quadtree. The root is a square of side `root_size` centred on the user's start. A frame
// taken at (x, y) goes to the leaf containing (x, y); when that leaf already holds data
// and its children would be no smaller than `min_size`, the leaf is first split into four
// equal children and the frame goes to the child containing (x, y) (so a cell subdivides
// only where the user has been twice, and at most once per frame). The frame then updates
// that node AND every ancestor up to the root, so a look-up far from where the user walked
// still finds recent, roughly relevant data instead of a default.
// Look-up at (x, y): for each direction, the deepest node on the path from the root to
// (x, y) that holds data for that direction ("nearest informed ancestor"). A direction
// never observed anywhere takes the mean of the observed directions of its hemisphere,
// else of all (flagged); an empty model has no lights.
// Positions outside the root square are not stored (counted in `outside_updates`); look-ups
// there use the root.
//
// Bipyramid. Six sectors: three up-facing (view z >= 0) and three down-facing, each a
// 120 deg wedge of azimuth centred on 0, 120 and 240 deg from +X. Each covers 2 pi / 3 sr;
// its light points at the sector's centroid direction, elevation +-atan(4 / (3 sqrt 3)) =
// +-37.6 deg (the mean of the unit vectors over the wedge). A frame updates the sector its
// VIEW direction falls in, i.e. the camera measures the light arriving from where it looks.
// Per sector: a running mean of radiance RGB and luminance (and CCT, averaged in mired),
// weight = frames seen, capped at `max_weight` so that old frames fade (0: no cap).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/light_list.h"
#include "core/vec3.h"
#include "estimate/exposure_metering.h"

namespace lp {

inline constexpr int kBipyramidSectors = 6;
// Sector of a view direction: 0..2 up (azimuth 0, 120, 240 deg), 3..5 down (same azimuths).
int bipyramid_sector(Vec3 view_direction);
// Unit centroid direction of a sector (where its light points).
Vec3 bipyramid_direction(int sector);
inline constexpr double kBipyramidSolidAngle = 2.0 * M_PI / 3.0;

struct SectorSample {
  double weight = 0;                   // frames averaged (capped at max_weight)
  std::array<double, 3> radiance{0, 0, 0};  // mean, W sr^-1 m^-2 per channel
  double luminance = 0;                // mean, cd m^-2
  double mired = 0;                    // mean 1e6 / CCT over frames with a colour
  double mired_weight = 0;
  int64_t last_frame = -1;
  bool informed() const { return weight > 0; }
};

struct QuadNode {
  double cx = 0, cy = 0, size = 0;  // centre and side length, metres
  int depth = 0;
  int parent = -1;
  std::array<int, 4> children{-1, -1, -1, -1};  // quadrants: (-x,-y), (+x,-y), (-x,+y), (+x,+y)
  std::array<SectorSample, kBipyramidSectors> sectors;
  bool leaf() const { return children[0] < 0; }
  bool informed() const;
  bool contains(double x, double y) const;
};

struct QuadtreeOptions {
  double origin_x = 0, origin_y = 0;  // the user's start: the root's centre
  double root_size = 32;              // side of the root square, m: must cover the scene
  double min_size = 1;                // smallest cell side, m (~ the distance between lights)
  double max_weight = 0;              // cap on a sector's weight (0: plain running mean)
};

// What a look-up returns for one sector.
struct SectorLookup {
  SectorSample sample;
  int node = -1;        // the node it came from; -1 when filled from other sectors
  int depth = -1;
  bool filled = false;  // never observed: mean of other sectors
};

class LightQuadtree {
 public:
  explicit LightQuadtree(const QuadtreeOptions& options);  // InputError on bad sizes

  // Stores one frame's reading; returns the node it was stored in, -1 when (x, y) lies
  // outside the root. `view_direction` need not be unit length but must not be zero.
  int update(double x, double y, Vec3 view_direction, const LightReading& reading, int64_t frame);

  // Per-sector nearest informed ancestor at (x, y); max_depth limits the descent
  // (0: the root only, i.e. one global estimate; -1: no limit). `min_weight` is how many
  // frames make a sector "informed": 1 is the paper's rule; more trades spatial detail for
  // less noise (a sector mean from one or two 60-degree views depends on whether a lamp
  // happened to be in them). When no node on the path has that many, the root is used.
  std::array<SectorLookup, kBipyramidSectors> lookup(double x, double y, int max_depth = -1,
                                                     double min_weight = 1) const;
  // Alternative to the nearest informed ancestor (not in the paper): hierarchical shrinkage.
  // Down the path from the root, each node's sector mean pulls the estimate with weight
  // w / (w + prior_weight): est = (w m + prior_weight est_parent) / (w + prior_weight). A
  // cell seen in a few frames moves the estimate a little, one seen in many moves it fully.
  std::array<SectorLookup, kBipyramidSectors> lookup_shrunk(double x, double y, double prior_weight) const;
  LightList lights_shrunk(double x, double y, double prior_weight) const;
  // Six directional lights (ids 0..5 = sectors, units radiance) for a renderer at (x, y).
  LightList lights_at(double x, double y, int max_depth = -1, double min_weight = 1) const;

  int leaf_at(double x, double y) const;  // -1 outside the root
  const std::vector<QuadNode>& nodes() const { return nodes_; }
  const QuadtreeOptions& options() const { return options_; }
  int64_t updates() const { return updates_; }
  int64_t outside_updates() const { return outside_; }
  int max_depth() const;

  // JSON model ("format": "lightprobe.metadata-model/1"); save writes atomically.
  std::string to_json() const;
  static LightQuadtree from_json(const std::string& text, const std::string& source);

 private:
  void split(int node);
  std::vector<int> path_to(double x, double y, int max_depth) const;
  QuadtreeOptions options_;
  std::vector<QuadNode> nodes_;
  int64_t updates_ = 0, outside_ = 0;
};

void save_model(const std::string& path, const LightQuadtree& tree);
LightQuadtree load_model(const std::string& path);

}  // namespace lp
