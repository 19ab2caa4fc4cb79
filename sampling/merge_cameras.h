// Merging the light lists of several cameras into one (Nikodym, Havran, Bittner 2013,
// section 4; issue 8). Inputs are light lists as the samplers publish them; the output is
// one light list for a point between the cameras (weights: e.g. position_weights).
//
// Every merge takes one weight per camera: finite, >= 0, not all zero (empty = equal
// weights). Weights are normalised to sum 1, so the merge is the weighted AVERAGE of the
// cameras, not their sum. Inputs must agree on units and method (InputError otherwise:
// q2tree lists cannot be merged with pharr/hemigon lists, nor pharr with hemigon, whose
// Halton points differ). The output's frame and timestamp are the newest input's.
//
// 1. merge_by_index (pharr, hemigon; paper 4.1): lights correspond by id (the Halton
//    index), assuming azimuth-aligned cameras sampled with the same sequence. For each id:
//    rgb = sum w_i rgb_i, solid_angle = sum w_i s_i, direction = normalize(sum w_i d_i)
//    (if that sum vanishes, opposite directions, the direction of the heaviest input).
//    An id missing from some inputs is merged over the inputs that have it, their weights
//    renormalised to sum 1; an id whose inputs all have weight 0 is left out. With equal
//    light counts (the usual case) every id is in every input and the total power is the
//    weighted average of the inputs' totals; with unequal counts it is not.
//
// 2. merge_q2trees (q2tree; paper 4.2, Algorithm 2). The ids are HEALPix NUNIQ nodes;
//    each input's leaves must partition the sphere (checked: InputError otherwise).
//    Step 1-2: the merged tree is the union of the inputs' trees (a node is interior if it
//    is interior in any input), so it has between max N_i and sum N_i leaves. The value
//    (rgb, luminance centroid) of camera i at a merged node is
//      - exact, the sum of i's leaves below it, when i resolves the node (the node is a
//        node of i's tree),
//      - else the node's share of i's enclosing (coarser) leaf: leaf value * 4^-(depth
//        difference), i.e. i's radiance assumed uniform inside its leaf,
//    and the merged value is sum_i w_i value_i. Values are then consistent sums (a node
//    equals the sum of its children, for every camera), so the paper's step 3
//    (renormalising children to their parent) is satisfied by construction, and the root
//    is the weighted average of the inputs' total powers (exactly, up to rounding).
//    Step 4-5: importance p = L^a dw^b (L luminance power, dw = pi / (3 4^level)) of
//    every interior node; the lowest-ranked interior node whose children are all leaves
//    is collapsed until the leaf count 12 + 3 S <= n (ranking as q2tree: importance,
//    ties to the smaller NUNIQ). As in q2tree, n - 2 <= count <= n, except that the merge
//    never splits below what the inputs resolved: if the merged tree has fewer leaves than
//    that, all of them are returned. n < 12 throws InputError.
//    Step 6: one light per leaf: id = NUNIQ, rgb = merged value, solid_angle of the
//    level, direction = normalize(sum_i w_i c_i) with c_i camera i's luminance centroid
//    over the leaf, built from its leaves as sum(power * direction) (a published leaf
//    only knows its centroid's direction, not how concentrated its light is, so each
//    input leaf counts as if concentrated at its centroid), a coarser leaf's share as
//    located at the node's centre. A zero-power leaf gets its quad centre. Inputs made
//    with q2_jitter merge to the weighted average of their jittered points.
//
//    The paper states that the merge equals the Q2-tree of the averaged map. What is true
//    (tests/sampling/merge_cameras_test.cpp):
//    - Exactly, when the inputs have the same leaf set and a = 1 (the default): the
//      Q2-tree of the weighted-average map at any n up to the inputs' count is the merged
//      tree reduced to n: same ids, powers equal to rounding (with a = 1 the importance
//      is linear in power, so a node ranked above another in every input is ranked above
//      it in the average; every merged node is resolved by every input, so its power is
//      exact). Directions are then exact (1e-10 deg) only at the inputs' own n and when
//      each leaf's centroid concentration is the same in every input (one map a multiple
//      of the other); otherwise they are power-weighted averages of input directions:
//      0.03 / 0.0005 / 0.0001 deg off at n = 30 / 90 / 180 for maps shuffled inside the
//      leaves, and up to 0.1 deg for leaves the reduction merged (n = 30 -> 21).
//      Merging a camera with itself (any weights) returns its lights.
//    - Not in general. The average map's tree may split a node that NO input split (a
//      quad second-brightest in both cameras but brightest in neither): the merged tree
//      does not contain it, so no reduction can give it. Where an input's leaf is coarser
//      than the merged node, its power inside is a uniform guess, which can change the
//      ranking. Counterexample in the test: base quads (10, 9, 0) in one camera and
//      (0, 9, 10) in the other at n = 15: the average's tree splits the middle quad, the
//      merge cannot (diffuse error 0.107 against 0.066). The total power is always the
//      weighted average (1e-12). On the synthetic scene with the sun in two different
//      places (healpix nside 64) the merge picked the average map's ids at every n and
//      its diffuse error against the average map was 0.0188 / 0.0072 / 0.0024 / 0.00046
//      at n = 30 / 60 / 120 / 240, against 0.0180 / 0.0068 / 0.0024 / 0.00046 for the
//      Q2-tree of the average map (the difference: directions only).
//
// 3. merge_by_direction (any lists, also of different methods, with ids that do not
//    correspond: a pharr camera beside a q2tree one, a list with a light cut out, ids
//    repeated). Ids are ignored: every light of camera i is a point of power w_i rgb at its
//    direction. E(n) = sum_i w_i E_i(n) holds exactly for the union of these points, so the
//    union is sorted into a HEALPix tree (a cell splits while it holds points in more than
//    one level-12 pixel, 0.014 deg), each leaf holding the sum of its points at their
//    luminance centroid, and the tree is reduced to n leaves as merge_q2trees reduces one
//    (importance L^a dw^b). The output is a q2tree list (ids NUNIQ, leaves partition the
//    sphere, empty leaves with zero power), so it can be merged again. Total power is the
//    weighted average of the inputs' (exactly, up to rounding); a light moves by at most
//    the size of the leaf it ends in.
//
// 4. merge_available: the robust front for a merge client, over named inputs that may
//    stall or send lists that cannot be merged: see below.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/light_list.h"
#include "core/vec3.h"

namespace lp {

LightList merge_by_index(const std::vector<LightList>& cameras, const std::vector<double>& weights);

// Inverse-distance weights w_i ~ 1 / |p_i - target|^power, normalised to sum 1
// (power >= 0; 0 gives equal weights). A camera at the target (distance <= 1e-12 of the
// largest distance, or 0) gets weight 1 and the others 0 (several there share it
// equally). InputError on no cameras, non-finite coordinates or a bad power.
std::vector<double> position_weights(const std::vector<Vec3>& camera_positions, Vec3 target, double power = 2);

struct Q2MergeOptions {
  double luminance_exponent = 1.0;      // a, as SamplerOptions::q2_luminance_exponent
  double solid_angle_exponent = 0.25;   // b, as SamplerOptions::q2_solid_angle_exponent
};

LightList merge_q2trees(const std::vector<LightList>& cameras, const std::vector<double>& weights, int n,
                        const Q2MergeOptions& options = {});

LightList merge_by_direction(const std::vector<LightList>& cameras, const std::vector<double>& weights, int n,
                             const Q2MergeOptions& options = {});

// How lists are merged: by index when all are pharr, or all hemigon, each with unique
// ids; as Q2-trees when all are q2tree lists whose leaves partition the sphere; by
// direction otherwise (mixed or other methods, repeated ids, a broken tree).
enum class MergeMode { Index, Q2Tree, Direction };
const char* to_string(MergeMode mode);
MergeMode merge_mode(const std::vector<LightList>& cameras);

// Dispatch on merge_mode. Lists in different units throw InputError (nothing converts
// relative to radiance), as do the checks of the merge chosen (weights, n).
LightList merge_light_lists(const std::vector<LightList>& cameras, const std::vector<double>& weights, int n,
                            const Q2MergeOptions& options = {});

// Why a list cannot be merged at all, as a short code (for metrics labels) and a
// sentence: "empty" (no lights), "not_finite", "negative" (rgb or solid angle < 0),
// "not_unit" (a direction whose length is off 1 by more than 1e-6), "too_many" (over a
// million lights), "too_bright" (a channel's total over 1e300: sums of it would
// overflow). nullopt: it can be merged.
struct MergeProblem {
  std::string code;
  std::string detail;
};
std::optional<MergeProblem> merge_problem(const LightList& list);

// One camera as the merge client sees it: its latest light list (nullopt until the first
// arrives) and when that arrived (seconds, on the client's clock).
struct MergeInput {
  std::string name;
  std::optional<LightList> latest;
  double last_seen_s = 0;
};

struct MergeAvailableOptions {
  std::vector<double> weights;  // one per input (empty: equal); a dropped input's weight is dropped
  int n = 256;                  // q2tree light count
  Q2MergeOptions q2;
};

// A live input whose list was left out, and why (code as MergeProblem's, or "units").
struct MergeSkip {
  std::string name, code, detail;
};

// What merge_available keeps between calls and reports about the last one.
struct MergeState {
  std::optional<LightList> last_output;  // last merged list
  bool stale = false;                    // the last call merged nothing and repeated last_output
  std::vector<std::string> used;         // inputs merged by the last call
  std::vector<std::string> dropped;      // inputs left out by the last call (silent or never seen)
  std::vector<MergeSkip> skipped;        // live inputs left out by the last call: their lists cannot be merged
  MergeMode mode = MergeMode::Index;     // how the last output was merged
  std::string error;                     // why the last call's merge failed ("" when it did not)
};

// Merges the inputs that are alive: with a list and now_s - last_seen_s <= timeout_s.
// An input silent for longer is dropped (the others' weights renormalised), and taken
// back as soon as it delivers again (its last_seen_s moves): liveness is decided afresh
// on every call, so the output never stops while one input is alive. A live input whose
// list cannot be merged (merge_problem, or units other than the first usable input's)
// is skipped and reported in state.skipped. Lists of different methods or with ids that
// do not correspond are merged by direction (merge_mode). With nothing to merge, or a
// merge that fails, the last output is returned unchanged and state.stale set (an empty
// list, also flagged, before any output existed; state.error says why a merge failed).
// Never throws for what the inputs hold: only a bad timeout or weights of the wrong
// count (the caller's options) throw InputError.
LightList merge_available(const std::vector<MergeInput>& inputs, double now_s, double timeout_s, MergeState& state,
                          const MergeAvailableOptions& options = {});

}  // namespace lp
