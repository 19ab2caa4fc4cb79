// Q2-tree internals visible to tests and benchmarks (sampling/q2tree.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <optional>

#include "sampling/sampler.h"

namespace lp {

// Merge-and-split pairs the last prepare() of a q2tree sampler performed to bring the
// previous frame's tree up to date; nullopt when it did not update a tree (first frame,
// geometry change, q2_incremental off or exactness not guaranteed: place() rebuilds).
// Throws InputError when `sampler` is not a q2tree sampler.
std::optional<int> q2tree_last_update_operations(const Sampler& sampler);

// The rgb sums of node (level, ipix) as the tree sees them after the last prepare() (healpix
// input: the difference of two prefix entries; latlong and hemisphere maps: the node
// pyramid's float sums; its luminance is the node's importance). Throws InputError when
// `sampler` is not a q2tree sampler or has not prepared a map, or there is no such node.
std::array<double, 3> q2tree_node_rgb(const Sampler& sampler, int level, int64_t ipix);

}  // namespace lp
