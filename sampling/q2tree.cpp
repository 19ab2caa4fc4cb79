// Spherical Q2-tree sampling (Wan, Wong, Leung, EGSR 2005; as described by Nikodym,
// Havran, Bittner, section 3.2 and Algorithm 1).
//
// The sphere is cut into the 12 HEALPix base quads and a quadtree grows on each: the
// most important LEAF is split into its four equal-area children until the leaf count
// reaches n. Importance p = L^a * dw^b with L the leaf's luminance power (integral of
// luminance over the quad), dw = pi / (3 * 4^level) its solid angle, a and b from the
// options (Agarwal et al.'s a = 1, b = 1/4 by default).
//
// Key design: every node's sums are at hand in O(1), the role the paper gives to summed-area
// tables: r, g, b times dw (luminance is their linear combination) and luminance * dw *
// (x, y, z) for the luminance-weighted centroids. On a healpix map they come from a double
// prefix sum over the nested pixel array (a node at level l is ONE CONTIGUOUS RANGE of it,
// [ipix << 2(L-l), (ipix+1) << 2(L-l)) for finest level L, so its sums are two entries'
// difference). On a latlong or hemisphere map they are a pyramid of float sums: each healpix
// pixel's from its source pixels, each coarser node's from its four children,
// (c0 + c1) + (c2 + c3). That took one pass over the map in row order and a quarter pass per
// level instead of a gather of every pixel in nested order into a 48-byte double entry per
// healpix pixel (4.8-5.3x a plain read of the map; see sampling/q2tree_sums.cpp). Each sum
// is its own node's, so its error is relative to that node (a few float roundings: lights
// within 2e-7 of the double sums, tests/sampling/q2tree_float_bins_test.cpp), where a float
// prefix would have made a dim node after a bright one in the same range as uncertain as the
// bright one. The leaves partition the sphere, so the sum of the leaves' rgb is the map's
// total power up to float rounding.
//
// Input: a healpix map is used as it is (its nside; q2_nside, when set and smaller, only
// caps the tree depth). Latlong and hemisphere maps are binned into healpix pixels at
// nside = q2_nside, or, when 0, the largest power of two (1..256) whose pixels are no
// smaller than the input's mean pixel (4 pi or 2 pi / pixel count). The binning
// geometry (which healpix pixel each source pixel's centre falls in) depends only on layout
// and size and is cached, so a frame costs one pass over the map in row order (in bands of
// rows on all cores, the same bits as one pass) and the pyramid's levels. Each source pixel
// gives its rgb * (its solid angle, in float) to exactly one healpix pixel, so power is
// preserved up to float rounding; invalid pixels give nothing. Leaves never split below the
// binned nside: a finest-level leaf is retired and the next leaf is split.
//
// Light count: the count goes 12, 15, 18, ... (12 + 3k). We stop at the first count
// >= n - 2, i.e. the largest count <= n, so n - 2 <= count <= n. n < 12 cannot be met
// (12 base quads) and throws InputError, as does n above the number of binned pixels.
//
// One light per leaf: rgb = sum of rgb * dw over the leaf, solid_angle = the leaf's
// solid angle, id = HEALPix NUNIQ of the node (4 * 4^level + nested index at
// nside 2^level; base quads 4..15), direction = luminance-weighted centroid of the
// leaf's pixel directions, normalised. With q2_jitter the direction is instead a fixed
// point inside the quad chosen by a hash (SplitMix64) of the NUNIQ id: offsets in the
// face's (x, y) coordinates, uniform in the central half of the quad on a 256 x 256
// sub-grid, so it is deterministic and stable from frame to frame. A leaf with zero
// power gets its quad centre.
//
// Between frames (q2_incremental, Nikodym et al. end of 3.2) the tree is kept and only
// repaired. Why that is exact: rank nodes by the total order the rebuild's heap uses,
// importance first, then the smaller NUNIQ. With a >= 0, b >= 0 and no negative pixel a
// child ranks strictly below its parent, in floating point too: a child's r, g, b are <= its
// parent's (healpix input: the prefix sums only grow, so a child's range differences are <=
// its parent's; row grids: a parent is (c0 + c1) + (c2 + c3) of non-negative children, and
// rounding is monotone, so it is >= each child, tested on hostile maps by
// Q2TreeFloatBins.NoChildsSumsExceedItsParentsOnHostileMaps), and so are its
// luminance (positive weights), power^a (pow is monotone; a = 0 gives 1 for both),
// dw^b (<= for b >= 0, equal for b = 0) and the product; where the importances tie
// (zero-power regions, b = 0, a = 0) the parent wins on its smaller NUNIQ. So the rebuild
// pops nodes in decreasing rank over the whole tree, and its interior set is exactly the
// S = (n - 12) / 3 highest-ranked nodes above the finest level (finest nodes are leaves
// it retires). For a kept tree re-evaluated on a new frame, the lowest interior node is
// always one whose four children are leaves (a "mergeable" node) and the highest node
// outside is always a splittable leaf, so: while the best splittable leaf ranks above
// the worst mergeable node, merge that node and split that leaf. The leaf count stays,
// every pair swaps an interior node for a higher-ranked one (so it ends), and when it
// ends the interior set is the top S again: the same leaves, so the same lights, bit for
// bit. The leaf is never a child of the merged node (it would rank below it). Growing or
// shrinking S by splitting the best leaf or merging the worst node keeps the top-S
// property too, so place() with another n repairs the tree the same way. The order
// argument needs a >= 0, b >= 0 and non-negative pixels: otherwise, and on any change
// of layout, size or nside, place() rebuilds.
#include <fmt/format.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <queue>
#include <tuple>
#include <vector>

#include "core/error.h"
#include "sampling/methods.h"
#include "sampling/q2tree.h"
#include "sampling/q2tree_sums.h"

#include "core/healpix.h"

namespace lp {
namespace {

constexpr int kMaxAutoNside = 256;
// Maps with fewer pixels are binned on one core (sampling/q2tree_sums.h's bands).
constexpr size_t kMinPixelsForBands = size_t(1) << 17;
// Groups of 64 healpix pixels per piece of the pyramid's three finest steps: 128 KB of bins.
constexpr size_t kGroupsPerChunk = 64;

bool is_power_of_two(int n) { return n > 0 && (n & (n - 1)) == 0; }
int log2_int(int n) {
  int l = 0;
  while ((1 << l) < n) ++l;
  return l;
}

// Auto binning resolution: the largest nside = 2^k (1..256) whose pixel solid angle
// 4 pi / (12 nside^2) is at least the input's mean pixel, so that healpix pixels hold one
// or more source pixel centres rather than leaving holes (1024 x 512 latlong -> 128,
// 2048 x 1024 -> 256, 360 x 90 hemisphere -> 64). One step finer would double the
// tree's depth budget at four times the node sums' memory for no better leaves.
int auto_nside(const EnvMap& map) {
  const double mean = layout_solid_angle(map.layout) / double(map.pixel_count());
  int nside = 1;
  while (nside < kMaxAutoNside && 4 * M_PI / (12.0 * 4.0 * nside * nside) >= mean * (1 - 1e-12)) nside *= 2;
  return nside;
}

// Geometry of binning one row-grid layout/size into healpix at one nside.
struct RowGridBinning {
  Layout layout;
  int width = 0, height = 0, nside = 0;
  // Per map pixel, row-major: the healpix pixel its centre falls in, tagged where its first
  // run starts (sampling/q2tree_sums.h).
  std::vector<uint32_t> target;
  // Healpix pixels up to the last one a source falls in: the nodes after them (a hemisphere
  // map's four southern base quads, a third of its pixels) are zero, never summed.
  size_t stored_pixels = 0;
  // Groups of 64 healpix pixels (g: pixels [64 g, 64 g + 64)) holding a source, as ranges
  // [first, end) of groups: the pyramid's three finest steps skip the others, whose nodes
  // stay zero (a hemisphere map's equatorial quads below the horizon, 22 % of the groups
  // at 360 x 90).
  std::vector<std::pair<size_t, size_t>> group_ranges;
  // The same cut into pieces of at most kGroupsPerChunk groups, for the cores.
  std::vector<std::pair<size_t, size_t>> group_chunks;
  std::vector<float> row;  // 8 per row: 1, 1, 1, sin theta, sin theta, cos theta, exact pixel solid angle, 0
  std::vector<float> col;  // 8 per column: 1, 1, 1, cos phi, sin phi, 1, 0, 0

  std::vector<float> cos_phi, sin_phi;  // per column: col's cos phi and sin phi in a row

  detail::RunTags tags;  // target's bands of rows

  detail::RowSources view() const {
    return {target.data(),         row.data(),          col.data(),
            cos_phi.data(),        sin_phi.data(),      tags.band_rows.data(),
            tags.band_later_runs.data(), tags.band_later_runs.size()};
  }
};

std::shared_ptr<const RowGridBinning> build_binning(const EnvMap& map, int nside) {
  auto b = std::make_shared<RowGridBinning>();
  b->layout = map.layout;
  b->width = map.width;
  b->height = map.height;
  b->nside = nside;
  const int w = map.width, h = map.height;
  const double span = map.layout == Layout::Hemisphere ? M_PI / 2 : M_PI;
  std::vector<double> row_sin(h), row_cos(h), col_cos(w), col_sin(w);
  b->row.assign(8 * size_t(h), 0.0f);
  for (int v = 0; v < h; ++v) {
    const double t = span * (v + 0.5) / h;
    row_sin[v] = std::sin(t);
    row_cos[v] = std::cos(t);
    float* r = b->row.data() + 8 * size_t(v);
    r[0] = r[1] = r[2] = 1.0f;
    r[3] = r[4] = float(row_sin[v]);
    r[5] = float(row_cos[v]);
    r[6] = float(pixel_solid_angle(map, size_t(v) * size_t(w)));
  }
  b->col.assign(8 * size_t(w), 0.0f);
  for (int u = 0; u < w; ++u) {
    const double p = 2 * M_PI * (u + 0.5) / w;
    col_cos[u] = std::cos(p);
    col_sin[u] = std::sin(p);
    float* c = b->col.data() + 8 * size_t(u);
    c[0] = c[1] = c[2] = c[5] = 1.0f;
    c[3] = float(col_cos[u]);
    c[4] = float(col_sin[u]);
    b->cos_phi.push_back(c[3]);
    b->sin_phi.push_back(c[4]);
  }
  b->target.resize(map.pixel_count());
  // From each row's exact cos and sin theta and each column's phi, not from the direction
  // vector: healpix_pixel's square root, division and arc tangent a pixel took 25-27 ms of CPU
  // on a 1024 x 512 map, the largest cost of a one-shot `sample --method q2tree`. The pixels
  // are the same (Healpix.APixelFromAGridsAnglesIsThePixelOfItsDirection compares every one).
  std::vector<double> col_phi(w);
  for (int u = 0; u < w; ++u) col_phi[u] = 2 * M_PI * (u + 0.5) / w;
  tbb::parallel_for(0, h, [&](int v) {
    for (int u = 0; u < w; ++u)
      b->target[size_t(v) * w + u] = uint32_t(healpix_pixel_at(nside, row_cos[v], row_sin[v], col_phi[u]));
  });
  b->stored_pixels = size_t(*std::max_element(b->target.begin(), b->target.end())) + 1;
  std::vector<uint8_t> seen(12 * size_t(nside) * size_t(nside), 0);
  for (const uint32_t t : b->target) seen[t] = 1;
  // Bands of rows for the cores, on maps large enough to repay the threads' start (a 360 x 90
  // hemisphere's prepare is 40 us).
  const size_t bands =
      map.pixel_count() >= kMinPixelsForBands ? size_t(std::clamp(tbb::info::default_concurrency(), 1, 8)) : 1;
  b->tags = detail::q2tree_tag_runs(b->target.data(), size_t(w), size_t(h), bands);
  for (size_t g = 0; 64 * g < b->stored_pixels; ++g) {
    const auto first = seen.begin() + std::ptrdiff_t(64 * g);
    if (std::find(first, first + std::ptrdiff_t(std::min<size_t>(64, seen.size() - 64 * g)), 1) - first == 64) continue;
    if (!b->group_ranges.empty() && b->group_ranges.back().second == g)
      ++b->group_ranges.back().second;
    else
      b->group_ranges.emplace_back(g, g + 1);
  }
  for (const auto& [first, end] : b->group_ranges)
    for (size_t g = first; g < end; g += kGroupsPerChunk)
      b->group_chunks.emplace_back(g, std::min(end, g + kGroupsPerChunk));
  return b;
}

// Process-wide cache of binning geometry, keyed by layout, size and nside (a few entries:
// a live stream uses one). Samplers hold a shared_ptr, so eviction never pulls a table
// from under a running prepare.
std::shared_ptr<const RowGridBinning> cached_binning(const EnvMap& map, int nside) {
  static std::mutex mutex;
  static std::list<std::shared_ptr<const RowGridBinning>> cache;
  std::lock_guard lock(mutex);
  for (auto it = cache.begin(); it != cache.end(); ++it) {
    const auto& b = **it;
    if (b.layout == map.layout && b.width == map.width && b.height == map.height && b.nside == nside) {
      cache.splice(cache.begin(), cache, it);
      return cache.front();
    }
  }
  auto b = build_binning(map, nside);
  cache.push_front(b);
  if (cache.size() > 4) cache.pop_back();
  return b;
}

// Unit directions of healpix pixel centres (float), cached per nside.
std::shared_ptr<const std::vector<float>> cached_healpix_directions(int nside) {
  static std::mutex mutex;
  static std::list<std::pair<int, std::shared_ptr<const std::vector<float>>>> cache;
  std::lock_guard lock(mutex);
  for (auto it = cache.begin(); it != cache.end(); ++it)
    if (it->first == nside) {
      cache.splice(cache.begin(), cache, it);
      return cache.front().second;
    }
  const size_t npix = 12 * size_t(nside) * size_t(nside);
  auto dirs = std::make_shared<std::vector<float>>(3 * npix);
  tbb::parallel_for(size_t(0), npix, [&](size_t i) {
    const Vec3 d = healpix_direction(nside, int64_t(i));
    (*dirs)[3 * i] = float(d.x), (*dirs)[3 * i + 1] = float(d.y), (*dirs)[3 * i + 2] = float(d.z);
  });
  cache.emplace_front(nside, dirs);
  if (cache.size() > 4) cache.pop_back();
  return dirs;
}

// Sums over a node, or (healpix input) running sums over the nested pixel array: entry i
// holds the sum over pixels [0, i).
struct Prefix {
  double r = 0, g = 0, b = 0;  // rgb * dw
  double x = 0, y = 0, z = 0;  // luminance * dw * direction
};

uint64_t splitmix64(uint64_t x) {
  x += 0x9E3779B97F4A7C15ull;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

// Interleave the low 8 bits of ix (even bits) and iy (odd bits): nested index within a face.
uint64_t interleave8(uint32_t ix, uint32_t iy) {
  uint64_t r = 0;
  for (int bit = 0; bit < 8; ++bit) r |= uint64_t((ix >> bit) & 1) << (2 * bit) | uint64_t((iy >> bit) & 1) << (2 * bit + 1);
  return r;
}

class Q2TreeSampler final : public Sampler {
 public:
  explicit Q2TreeSampler(const SamplerOptions& options) : options_(options) {
    if (options.q2_nside != 0 && (!is_power_of_two(options.q2_nside) || options.q2_nside > 8192))
      throw InputError(fmt::format("q2tree: nside must be a power of two up to 8192, got {}", options.q2_nside));
    if (!std::isfinite(options.q2_luminance_exponent) || !std::isfinite(options.q2_solid_angle_exponent))
      throw InputError("q2tree: importance exponents must be finite");
  }

  Method method() const override { return Method::Q2Tree; }

  void prepare(const EnvMap& map) override {
    update_operations_.reset();
    const bool had_tree = tree_ready_ && !tree_broken_;
    tree_ready_ = false;  // until it matches this frame
    if (map.pixel_count() == 0) throw InputError("q2tree: the map is empty");
    upper_only_ = map.layout == Layout::Hemisphere;
    if (map.layout == Layout::Healpix)
      prepare_healpix(map);
    else
      prepare_row_grid(map);
    Prefix t;  // the map's sums: its twelve base quads'
    for (int f = 0; f < 12; ++f) {
      const Prefix q = node_sums(0, f);
      t.r += q.r, t.g += q.g, t.b += q.b;
    }
    const double rgb[3] = {t.r, t.g, t.b};
    const double lum = luminance(rgb);
    if (!std::isfinite(lum)) throw InputError("q2tree: the map has non-finite pixels");
    if (!(lum > 0)) throw InputError("q2tree: the map is black (zero power): there is no light to sample");

    dw_pow_.resize(size_t(max_level_) + 1);
    for (int l = 0; l <= max_level_; ++l)
      dw_pow_[size_t(l)] = std::pow(M_PI / (3.0 * std::ldexp(1.0, 2 * l)), options_.q2_solid_angle_exponent);
    const TreeKey key{map.layout, map.width, map.height, finest_level_, max_level_};
    if (had_tree && key == tree_key_ && incremental_allowed()) {
      update_operations_ = update_tree();
      tree_ready_ = update_operations_.has_value();
    }
    if (!tree_ready_) clear_tree();
    tree_key_ = key;
  }

  // On a hemisphere map the quads wholly below the horizon hold no data: their lights (4 of
  // the 15 asked for with n = 16, rgb 0) are left out, and the tree is grown by as many as
  // that leaves the count short of, so that n - 2 <= count <= n still holds. A quad the
  // horizon crosses is a HEALPix pixel centred on the equator, symmetric about it: half of
  // its solid angle is the map's.
  std::vector<Light> place(int n) override {
    if (!upper_only_) return place_tree(n);
    const int cap_nside = 1 << max_level_;
    const int64_t capacity = 12 * int64_t(cap_nside) * cap_nside;
    std::vector<Light> lights;
    for (int grown = n;; grown += 3) {
      lights = place_tree(grown);
      lights.erase(std::remove_if(lights.begin(), lights.end(),
                                  [](const Light& l) { return quad_side(l.id) < 0; }),
                   lights.end());
      if (int(lights.size()) >= n - 2 || grown + 3 - 2 > capacity || grown > 2 * n + 12) break;
    }
    for (Light& l : lights)
      if (quad_side(l.id) == 0) l.solid_angle *= 0.5;
    return lights;
  }

  // -1 when the quad of NUNIQ `id` lies wholly below the horizon, 0 when its centre is on it,
  // +1 above.
  static int quad_side(uint64_t id) {
    int level = 0;
    while ((uint64_t(4) << (2 * (level + 1))) <= id) ++level;
    const int64_t ipix = int64_t(id - (uint64_t(4) << (2 * level)));
    const double z = healpix_direction(int64_t(1) << level, ipix).z;
    return z < -1e-12 ? -1 : z > 1e-12 ? 1 : 0;
  }

  std::vector<Light> place_tree(int n) {
    if (prefix_.empty() && levels_.empty()) throw InputError("q2tree: place() called before prepare()");
    if (n < 12)
      throw InputError(fmt::format("q2tree: needs n >= 12 lights (one per HEALPix base quad), got {}", n));
    const int cap_nside = 1 << max_level_;
    const int64_t capacity = 12 * int64_t(cap_nside) * cap_nside;
    if (n - 2 > capacity)
      throw InputError(fmt::format("q2tree: n = {} exceeds the {} HEALPix pixels at nside {}; raise the nside", n,
                                   capacity, cap_nside));
    if (!incremental_allowed()) return rebuild_lights(n);
    // The largest count 12 + 3 S <= n, the rebuild's first count >= n - 2.
    const int splits = (n - 12) / 3;
    if (!tree_ready_) init_tree();
    while (!tree_broken_ && tree_splits_ < splits) {
      const int x = top_leaf();
      std::pop_heap(leaf_heap_.begin(), leaf_heap_.end());
      leaf_heap_.pop_back();
      split(x);
      ++tree_splits_;
    }
    while (!tree_broken_ && tree_splits_ > splits) {
      const int m = top_mergeable();
      std::pop_heap(merge_heap_.begin(), merge_heap_.end(), std::greater<>());
      merge_heap_.pop_back();
      merge(m);
      --tree_splits_;
    }
    if (tree_broken_) {
      clear_tree();
      return rebuild_lights(n);
    }
    std::vector<Light> lights;
    lights.reserve(size_t(12 + 3 * splits));
    for (const TreeNode& node : nodes_)
      if (node.live && node.child < 0) lights.push_back(make_light(node.level, node.ipix));
    std::sort(lights.begin(), lights.end(), [](const Light& x, const Light& y) { return x.id < y.id; });
    return lights;
  }

  std::optional<int> last_update_operations() const { return update_operations_; }

  std::array<double, 3> node_rgb(int level, int64_t ipix) const {
    if (prefix_.empty() && levels_.empty()) throw InputError("q2tree: node_rgb() called before prepare()");
    if (level < 0 || level > finest_level_ || ipix < 0 || ipix >= 12 * (int64_t(1) << (2 * level)))
      throw InputError(fmt::format("q2tree: no node {} at level {}", ipix, level));
    const Prefix s = node_sums(level, ipix);
    return {s.r, s.g, s.b};
  }

 private:
  // The greedy rebuild of Algorithm 1: split the most important leaf until n - 2 <= count.
  std::vector<Light> rebuild_lights(int n) const {
    // Leaves in a max-heap by importance; ties go to the smaller NUNIQ so that the
    // tree does not depend on the heap's internal order.
    using Entry = std::tuple<double, int64_t, int, int64_t>;  // importance, -nuniq, level, ipix
    std::vector<Entry> heap;
    heap.reserve(size_t(n) + 4);
    auto push = [&](int level, int64_t ipix) {
      heap.emplace_back(importance(level, ipix), -nuniq(level, ipix), level, ipix);
      std::push_heap(heap.begin(), heap.end());
    };
    for (int f = 0; f < 12; ++f) push(0, f);
    std::vector<std::pair<int, int64_t>> retired;  // finest-level leaves: cannot split
    size_t count = 12;
    while (count < size_t(n - 2) && !heap.empty()) {
      std::pop_heap(heap.begin(), heap.end());
      const auto [imp, neg_id, level, ipix] = heap.back();
      heap.pop_back();
      if (level >= max_level_) {
        retired.emplace_back(level, ipix);
        continue;
      }
      for (int c = 0; c < 4; ++c) push(level + 1, 4 * ipix + c);
      count += 3;
    }

    std::vector<Light> lights;
    lights.reserve(count);
    for (const auto& e : heap) lights.push_back(make_light(std::get<2>(e), std::get<3>(e)));
    for (const auto& [level, ipix] : retired) lights.push_back(make_light(level, ipix));
    std::sort(lights.begin(), lights.end(), [](const Light& x, const Light& y) { return x.id < y.id; });
    return lights;
  }

  static int64_t nuniq(int level, int64_t ipix) { return (int64_t(4) << (2 * level)) + ipix; }

  // p = L^a * dw^b, the one definition both the rebuild and the kept tree use.
  double importance(int level, int64_t ipix) const {
    const double power = std::max(0.0, node_luminance_power(level, ipix));
    const double a = options_.q2_luminance_exponent;
    const double pa = a == 1.0 ? power : std::pow(power, a);
    return pa * dw_pow_[level];
  }

  // When the kept tree is exact (see the top of the file).
  bool incremental_allowed() const {
    return options_.q2_incremental && options_.q2_luminance_exponent >= 0 && options_.q2_solid_angle_exponent >= 0 &&
           !negative_pixels_;
  }

  // ---- The kept tree. Nodes live in a pool; the four children of a node are one block.
  struct TreeNode {
    int64_t ipix = 0;
    double importance = 0;
    int parent = -1;  // -1: base quad
    int child = -1;   // first of four children, -1: leaf
    int level = 0;
    bool live = false;
  };
  // Heap entries compare in the rebuild's total order: importance, then the smaller NUNIQ.
  using HeapEntry = std::tuple<double, int64_t, int>;  // importance, -nuniq, node

  HeapEntry heap_entry(int i) const {
    const TreeNode& node = nodes_[size_t(i)];
    return {node.importance, -nuniq(node.level, node.ipix), i};
  }
  bool splittable(int i) const {
    const TreeNode& node = nodes_[size_t(i)];
    return node.live && node.child < 0 && node.level < max_level_;
  }
  bool mergeable(int i) const {
    const TreeNode& node = nodes_[size_t(i)];
    if (!node.live || node.child < 0) return false;
    for (int k = 0; k < 4; ++k)
      if (nodes_[size_t(node.child + k)].child >= 0) return false;
    return true;
  }
  // An entry still describes its node (pool slots are reused; entries are never erased).
  bool current(const HeapEntry& e) const { return heap_entry(std::get<2>(e)) == e && nodes_[size_t(std::get<2>(e))].live; }

  // Best splittable leaf / worst mergeable node, left on top of their heap; -1 if none.
  int top_leaf() {
    while (!leaf_heap_.empty()) {
      const HeapEntry& e = leaf_heap_.front();
      if (current(e) && splittable(std::get<2>(e))) return std::get<2>(e);
      std::pop_heap(leaf_heap_.begin(), leaf_heap_.end());
      leaf_heap_.pop_back();
    }
    return -1;
  }
  int top_mergeable() {
    while (!merge_heap_.empty()) {
      const HeapEntry& e = merge_heap_.front();
      if (current(e) && mergeable(std::get<2>(e))) return std::get<2>(e);
      std::pop_heap(merge_heap_.begin(), merge_heap_.end(), std::greater<>());
      merge_heap_.pop_back();
    }
    return -1;
  }
  void push_leaf(int i) {
    leaf_heap_.push_back(heap_entry(i));
    std::push_heap(leaf_heap_.begin(), leaf_heap_.end());
  }
  void push_mergeable(int i) {
    merge_heap_.push_back(heap_entry(i));
    std::push_heap(merge_heap_.begin(), merge_heap_.end(), std::greater<>());
  }

  void split(int i) {
    if (i < 0) {
      tree_broken_ = true;
      return;
    }
    int block;
    if (!free_blocks_.empty()) {
      block = free_blocks_.back();
      free_blocks_.pop_back();
    } else {
      block = int(nodes_.size());
      nodes_.resize(nodes_.size() + 4);
    }
    TreeNode& node = nodes_[size_t(i)];
    node.child = block;
    for (int k = 0; k < 4; ++k) {
      TreeNode& c = nodes_[size_t(block + k)];
      c.level = node.level + 1;
      c.ipix = 4 * node.ipix + k;
      c.importance = importance(c.level, c.ipix);
      c.parent = i;
      c.child = -1;
      c.live = true;
      if (std::isnan(c.importance)) tree_broken_ = true;
      if (c.level < max_level_) push_leaf(block + k);
    }
    push_mergeable(i);
  }

  void merge(int i) {
    if (i < 0) {
      tree_broken_ = true;
      return;
    }
    TreeNode& node = nodes_[size_t(i)];
    for (int k = 0; k < 4; ++k) nodes_[size_t(node.child + k)].live = false;
    free_blocks_.push_back(node.child);
    node.child = -1;
    push_leaf(i);
    if (node.parent >= 0 && mergeable(node.parent)) push_mergeable(node.parent);
  }

  void clear_tree() {
    nodes_.clear();
    free_blocks_.clear();
    leaf_heap_.clear();
    merge_heap_.clear();
    tree_ready_ = false;
    tree_broken_ = false;
    tree_splits_ = 0;
  }

  // The 12 base quads as leaves, for the current frame.
  void init_tree() {
    clear_tree();
    nodes_.resize(12);
    for (int f = 0; f < 12; ++f) {
      nodes_[size_t(f)] = {f, importance(0, f), -1, -1, 0, true};
      if (std::isnan(nodes_[size_t(f)].importance)) tree_broken_ = true;
    }
    rebuild_heaps();
    tree_ready_ = true;
  }

  void rebuild_heaps() {
    leaf_heap_.clear();
    merge_heap_.clear();
    for (int i = 0; i < int(nodes_.size()); ++i) {
      if (splittable(i)) leaf_heap_.push_back(heap_entry(i));
      if (mergeable(i)) merge_heap_.push_back(heap_entry(i));
    }
    std::make_heap(leaf_heap_.begin(), leaf_heap_.end());
    std::make_heap(merge_heap_.begin(), merge_heap_.end(), std::greater<>());
  }

  // Re-evaluates the kept tree on the current frame and restores the top-S order by
  // merge-and-split pairs. Returns the number of pairs, or nullopt if the tree was dropped.
  std::optional<int> update_tree() {
    for (TreeNode& node : nodes_) {
      if (!node.live) continue;
      node.importance = importance(node.level, node.ipix);
      if (std::isnan(node.importance)) return std::nullopt;
    }
    rebuild_heaps();
    int pairs = 0;
    for (;;) {
      const int x = top_leaf();
      const int m = top_mergeable();
      if (x < 0 || m < 0 || !(heap_entry(x) > heap_entry(m))) break;
      // Cannot happen (a child ranks below its parent); drop the tree rather than guess.
      if (nodes_[size_t(x)].parent == m) return std::nullopt;
      std::pop_heap(leaf_heap_.begin(), leaf_heap_.end());
      leaf_heap_.pop_back();
      std::pop_heap(merge_heap_.begin(), merge_heap_.end(), std::greater<>());
      merge_heap_.pop_back();
      merge(m);
      split(x);
      ++pairs;
      if (tree_broken_) return std::nullopt;
    }
    return pairs;
  }

  // Prefix entry i of a healpix map: the sum over pixels [0, i).
  const Prefix& entry(size_t i) const { return prefix_[i]; }

  // A node's sums: on a healpix map the difference of two prefix entries, on a row grid its
  // float sums in the node pyramid.
  Prefix node_sums(int level, int64_t ipix) const {
    if (levels_.empty()) {
      const auto [b, e] = range(level, ipix);
      const Prefix& p = entry(b);
      const Prefix& q = entry(e);
      return {q.r - p.r, q.g - p.g, q.b - p.b, q.x - p.x, q.y - p.y, q.z - p.z};
    }
    const float* f = levels_[size_t(level)] + 8 * size_t(ipix);
    return {f[0], f[1], f[2], f[3], f[4], f[5]};
  }

  // Finest-level range of a node.
  std::pair<size_t, size_t> range(int level, int64_t ipix) const {
    const int shift = 2 * (finest_level_ - level);
    return {size_t(ipix) << shift, size_t(ipix + 1) << shift};
  }

  double node_luminance_power(int level, int64_t ipix) const {
    const Prefix s = node_sums(level, ipix);
    return 0.2126 * s.r + 0.7152 * s.g + 0.0722 * s.b;
  }

  Light make_light(int level, int64_t ipix) const {
    const Prefix s = node_sums(level, ipix);
    Light l;
    l.id = (uint64_t(4) << (2 * level)) + uint64_t(ipix);
    l.rgb = {s.r, s.g, s.b};
    l.solid_angle = M_PI / (3.0 * std::ldexp(1.0, 2 * level));
    const double power = luminance(l.rgb.data());
    const Vec3 c{s.x, s.y, s.z};
    const double len = length(c);
    if (!(power > 0) || !(len > 1e-12 * power)) {
      l.direction = quad_point(level, ipix, 128, 128);
    } else if (options_.q2_jitter) {
      const uint64_t h = splitmix64(l.id);
      l.direction = quad_point(level, ipix, 64 + uint32_t(h & 127), 64 + uint32_t((h >> 32) & 127));
    } else {
      l.direction = (1.0 / len) * c;
    }
    return l;
  }

  // A point of the quad (level, ipix) at face offsets (ix, iy) / 256 on a 256 x 256
  // sub-grid (128, 128: the corner shared by the four central sub-pixels, the centre).
  static Vec3 quad_point(int level, int64_t ipix, uint32_t ix, uint32_t iy) {
    if (ix == 128 && iy == 128) return healpix_direction(int64_t(1) << level, ipix);
    return healpix_direction(int64_t(1) << (level + 8), (ipix << 16) + int64_t(interleave8(ix, iy)));
  }

  void prepare_healpix(const EnvMap& map) {
    const int nside = map.nside;
    if (!is_power_of_two(nside) || map.pixel_count() != 12 * size_t(nside) * size_t(nside))
      throw InputError(fmt::format("q2tree: healpix map has {} pixels for nside {}", map.pixel_count(), nside));
    finest_level_ = log2_int(nside);
    max_level_ = options_.q2_nside ? std::min(finest_level_, log2_int(options_.q2_nside)) : finest_level_;
    const auto dirs = cached_healpix_directions(nside);
    const size_t npix = map.pixel_count();
    const double dw = 4 * M_PI / double(npix);
    levels_.clear();
    prefix_.resize(npix + 1);
    Prefix s;
    prefix_[0] = s;
    const float* px = map.rgb.data();
    const float* d = dirs->data();
    bool negative = false;
    for (size_t i = 0; i < npix; ++i) {
      if (map.is_valid(i)) {
        const double r = px[3 * i] * dw, g = px[3 * i + 1] * dw, b = px[3 * i + 2] * dw;
        negative |= (r < 0) | (g < 0) | (b < 0);
        const double wl = 0.2126 * r + 0.7152 * g + 0.0722 * b;
        s.r += r, s.g += g, s.b += b;
        s.x += wl * d[3 * i], s.y += wl * d[3 * i + 1], s.z += wl * d[3 * i + 2];
      }
      prefix_[i + 1] = s;
    }
    negative_pixels_ = negative;
  }

  void prepare_row_grid(const EnvMap& map) {
    if (map.width > 65535 || map.height > 65535)
      throw InputError(fmt::format("q2tree: {} is too large (at most 65535 pixels a side)", describe_size(map)));
    const int nside = options_.q2_nside ? options_.q2_nside : auto_nside(map);
    if (!binning_ || binning_->layout != map.layout || binning_->width != map.width ||
        binning_->height != map.height || binning_->nside != nside)
      binning_ = cached_binning(map, nside);
    const RowGridBinning& bin = *binning_;
    finest_level_ = max_level_ = log2_int(nside);
    // Each healpix pixel's sums, the map read in row order, then each coarser level's from
    // the one below (sampling/q2tree_sums.h). Levels past the stored pixels stay zero.
    const int finest = finest_level_;
    size_t offset = 0;
    std::vector<size_t> offsets(size_t(finest) + 1);
    for (int l = finest; l >= 0; --l) offsets[size_t(l)] = offset, offset += 12 * (size_t(1) << (2 * l));
    if (pyramid_binning_ != binning_) {  // pixels no source falls in must read zero
      pyramid_.assign(offset, Bin{});
      pyramid_binning_ = binning_;
    }
    levels_.resize(size_t(finest) + 1);
    for (int l = 0; l <= finest; ++l) levels_[size_t(l)] = pyramid_[offsets[size_t(l)]].v;
    prefix_.clear();
    const uint8_t* valid = map.valid.empty() ? nullptr : map.valid.data();
    const bool negative = detail::q2tree_bin_sums(map.rgb.data(), valid, size_t(map.width), size_t(map.height),
                                                  bin.view(), pyramid_[0].v);
    size_t stored = bin.stored_pixels;
    int l = finest - 1;
    if (finest >= 3) {  // the three finest steps in one pass (whole groups: the rest is zeros)
      stored = (stored + 63) / 64;
      const auto quads = [&](size_t c) {
        const auto [first, end] = bin.group_chunks[c];
        detail::q2tree_quad_sums3(levels_[size_t(finest)] + 512 * first, end - first,
                                  levels_[size_t(finest) - 1] + 128 * first, levels_[size_t(finest) - 2] + 32 * first,
                                  levels_[size_t(finest) - 3] + 8 * first);
      };
      if (bin.tags.band_later_runs.size() > 1)
        tbb::parallel_for(size_t(0), bin.group_chunks.size(), quads);
      else
        for (size_t c = 0; c < bin.group_chunks.size(); ++c) quads(c);
      l = finest - 4;
    }
    for (; l >= 0; --l) {
      stored = (stored + 3) / 4;
      detail::q2tree_quad_sums(levels_[size_t(l) + 1], stored, levels_[size_t(l)]);
    }
    negative_pixels_ = negative;
  }

  // Geometry a kept tree belongs to.
  struct TreeKey {
    Layout layout = Layout::LatLong;
    int width = 0, height = 0, finest_level = -1, max_level = -1;
    bool operator==(const TreeKey&) const = default;
  };

  SamplerOptions options_;
  bool upper_only_ = false;  // a hemisphere map: no data below the horizon
  std::vector<double> dw_pow_;    // dw^b per level
  bool negative_pixels_ = false;  // this frame has a negative contribution
  TreeKey tree_key_;
  std::vector<TreeNode> nodes_;
  std::vector<int> free_blocks_;
  std::vector<HeapEntry> leaf_heap_;   // max-heap of splittable leaves (lazy: stale entries skipped)
  std::vector<HeapEntry> merge_heap_;  // min-heap of mergeable interior nodes (lazy)
  bool tree_ready_ = false;   // nodes_ hold the tree of tree_splits_ splits for this frame
  bool tree_broken_ = false;  // a NaN importance: the order is undefined, rebuild
  int tree_splits_ = 0;
  std::optional<int> update_operations_;
  std::shared_ptr<const RowGridBinning> binning_;
  std::vector<Prefix> prefix_;  // healpix input: the prefix entries
  // Row grids: every node's sums in float (r, g, b, x, y, z and two unused), the finest level
  // first, then each coarser one; levels_[l] points at level l's first node. 32-byte aligned:
  // one vector load and store a node (sampling/q2tree_sums.h).
  struct alignas(32) Bin {
    float v[8] = {0, 0, 0, 0, 0, 0, 0, 0};
  };
  std::vector<Bin> pyramid_;
  std::vector<float*> levels_;
  std::shared_ptr<const RowGridBinning> pyramid_binning_;  // the geometry pyramid_ was zeroed for
  int finest_level_ = 0;  // level of the map's (or binning's) healpix pixels
  int max_level_ = 0;     // deepest level a leaf may reach
};

}  // namespace

std::unique_ptr<Sampler> make_q2tree_sampler(const SamplerOptions& options) {
  return std::make_unique<Q2TreeSampler>(options);
}

std::optional<int> q2tree_last_update_operations(const Sampler& sampler) {
  const auto* q2 = dynamic_cast<const Q2TreeSampler*>(&sampler);
  if (!q2) throw InputError(fmt::format("q2tree_last_update_operations: the sampler is {}, not q2tree",
                                        to_string(sampler.method())));
  return q2->last_update_operations();
}

std::array<double, 3> q2tree_node_rgb(const Sampler& sampler, int level, int64_t ipix) {
  const auto* q2 = dynamic_cast<const Q2TreeSampler*>(&sampler);
  if (!q2) throw InputError(fmt::format("q2tree_node_rgb: the sampler is {}, not q2tree", to_string(sampler.method())));
  return q2->node_rgb(level, ipix);
}

}  // namespace lp
