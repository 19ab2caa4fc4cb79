#include "calib/model_selection.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <numeric>
#include <optional>
#include <random>
#include <utility>

#include "calib/parallel_jobs.h"
#include "calib/projection_difference.h"
#include "core/error.h"

namespace lp {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
// A fit of every view whose RMS is this much above its held-out RMS stopped short (on the
// shared sets the ratio is 0.87-0.99): solve_candidates refits it from a half's model.
constexpr double kStoppedShortFactor = 1.2;

std::string px3(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", v);
  return buf;
}

std::string fmt_out_of_field(const WideField& field, size_t sample_views, size_t used_views, double limit_deg) {
  char buf[240];
  std::snprintf(buf, sizeof buf,
                "screened out: %s's fit of %zu of the %zu views sees corners at %.0f deg, beyond a perspective "
                "model's reach (%.0f); not fitted",
                candidate_name(field.seen_by).c_str(), sample_views, used_views, field.deg, limit_deg);
  return buf;
}

std::string fmt_screened(double rms_px, double limit_px) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "screened out: RMS %.3f px of every view above %.3g px, halves not fitted", rms_px,
                limit_px);
  return buf;
}

// The order the candidates' solves start in (run_jobs): a seed that needs another fit
// (stereographic: Kannala-Brandt's, else pinhole's; splined: stereographic's) after it, and
// the slow solves first so that the last job to finish is a short one.
int start_rank(LensType t) {
  switch (t) {
    case LensType::OmnidirMei: return 0;
    case LensType::OpenCV8: return 1;
    case LensType::KannalaBrandt: return 2;
    case LensType::OpenCV5: return 3;
    case LensType::Pinhole: return 4;
    case LensType::Stereographic: return 5;
    case LensType::SplinedStereographic: return 6;
    default: return 3;
  }
}

using SolveJob = std::pair<CandidateSolver*, LensType>;

// The order warm refits start in, dearest first (stereo's split refits: the spline's 33 ms,
// the rational model's 19, Mei's 4, Kannala-Brandt's 3, plumb_bob's 2).
int warm_refit_rank(LensType t) {
  switch (t) {
    case LensType::SplinedStereographic: return 0;
    case LensType::OpenCV8: return 1;
    case LensType::OmnidirMei: return 2;
    case LensType::KannalaBrandt: return 3;
    default: return 4;
  }
}

ViewSubset half_of(const ViewSubset& used, int h) {
  ViewSubset s;
  for (size_t i = 0; i < used.size(); ++i)
    if (int(i % 2) == h) s.push_back(used[i]);
  return s;
}

// One table row: full fit, halves, cross-validation, held-out RMS. screen_rms_px: a full fit
// above it is screened out (see CandidateOptions::screen_rms_px), its halves not fitted.
// The halves' rays and held-out RMS are four jobs (`parallel`): the row made last, after the
// stage's longest solve (stereo's spline: mrcal unprojects its grids pixel by pixel), no
// longer runs on one core while the other waits.
ModelCandidate evaluate(const CalibrationProblem& pr, CandidateFits& fits, LensType type, double screen_rms_px,
                        bool parallel) {
  ModelCandidate c;
  c.name = candidate_name(type);
  const ModelFit& f = fits.full.get(type);
  if (!f.ok) {
    c.error = f.error;
    return c;
  }
  c.lensmodel = f.model.lensmodel;
  c.solver = f.solver;
  c.params = f.params;
  c.rms_px = fit_rms(pr, f, fits.used);
  c.model = f.model;
  c.model.rms_reprojection_px = c.rms_px;
  if (c.rms_px > screen_rms_px) {
    c.screened = true;
    c.error = fmt_screened(c.rms_px, screen_rms_px);
    return c;
  }
  const ModelFit& a = fits.halves[0].get(type);
  const ModelFit& b = fits.halves[1].get(type);
  if (!a.ok || !b.ok) {
    c.error = "a half of the views could not be fitted: " + (a.ok ? b.error : a.error);
    return c;
  }
  GridRays rays[2];
  double heldout[2];  // each half's model on the other half's views
  run_jobs(4, [&](size_t k) {
    const size_t h = k % 2;
    const ModelFit& f = h == 0 ? a : b;
    if (k < 2)
      rays[h] = grid_rays(f.model, fits.mask, fits.step);
    else
      heldout[h] = heldout_rms(pr, f, fits.half[1 - h]);
  }, parallel ? 0 : 1);
  const ProjectionDiff d = projection_difference(rays[0], b.model, rays[1]);
  c.cross_validation_px = d.samples > 0 ? d.rms_px : kInf;
  c.cross_validation_median_px = d.median_px;
  c.heldout_rms_px = std::sqrt(0.5 * (heldout[0] * heldout[0] + heldout[1] * heldout[1]));
  c.model.cross_validation_px = c.cross_validation_px;
  c.ok = std::isfinite(c.cross_validation_px);
  if (!c.ok) c.error = "no covered pixel both half-models can image";
  return c;
}

// Candidates whose repeated splits are raced (SelectionOptions::race_dear_candidates): the
// richest model of each family, whose warm refits cost most (stereo's split refits: the
// spline's 41 ms, the rational model's 23; Mei's 5, Kannala-Brandt's 3, plumb_bob's 2).
bool raced_type(LensType t) { return t == LensType::SplinedStereographic || t == LensType::OpenCV8; }

// Finished: every split fitted, or one that could not be (the rest are not reported).
bool splits_finished(const ModelCandidate& c, size_t splits) {
  return c.cross_validation_splits_px.size() >= splits ||
         (!c.cross_validation_splits_px.empty() && !std::isfinite(c.cross_validation_splits_px.back()));
}

// Each listed row's split validations from the next one it lacks up to (not including)
// `upto`, refitted warm on every core, dearest first (each writes its own slot); appended
// in split order up to the first that could not be fitted. Slots the board warp's decision
// already filled (the same solves) are taken, not refitted.
void extend_over_splits(const CalibrationProblem& pr, CandidateFits& fits, std::vector<ModelCandidate>& table,
                        const std::vector<std::vector<int>>& splits, const std::vector<std::pair<size_t, size_t>>& rows,
                        bool parallel) {
  struct Slot {
    size_t row, split;
    LensType type;
    bool known;
  };
  std::vector<Slot> slots;
  std::vector<SplitValidation> values;
  const auto& ks = fits.known_splits;
  const bool have_known = ks && ks->splits == splits && ks->values.size() == splits.size();
  for (const auto& [row, upto] : rows) {
    const LensType type = candidate_lens_type(table[row].name);
    for (size_t k = table[row].cross_validation_splits_px.size(); k < std::min(upto, splits.size()); ++k) {
      const bool known = have_known && ks->type == type;
      slots.push_back({row, k, type, known});
      values.push_back(known ? ks->values[k] : SplitValidation{kInf, kInf});
    }
  }
  std::vector<size_t> start;
  for (size_t j = 0; j < slots.size(); ++j)
    if (!slots[j].known) start.push_back(j);
  std::stable_sort(start.begin(), start.end(), [&](size_t a, size_t b) {
    return warm_refit_rank(slots[a].type) < warm_refit_rank(slots[b].type);
  });
  std::vector<SplitTask> tasks;
  for (size_t j : start) tasks.push_back({&pr, slots[j].type, &fits.full.get(slots[j].type), &splits[slots[j].split]});
  const std::vector<SplitValidation> got = split_validations(fits.used, tasks, fits.mask, fits.step, parallel);
  for (size_t q = 0; q < start.size(); ++q) values[start[q]] = got[q];
  for (size_t j = 0; j < slots.size(); ++j) {  // per row, in split order
    ModelCandidate& c = table[slots[j].row];
    if (splits_finished(c, splits.size()) || c.cross_validation_splits_px.size() != slots[j].split) continue;
    c.cross_validation_splits_px.push_back(values[j].cross_validation_px);
    c.heldout_splits_px.push_back(values[j].heldout_rms_px);
  }
}

// The lens's own family first, then fewer parameters (incumbent_pick's order, without its
// tie-break on the repeated cross-validation).
std::pair<int, int> rule_rank(const ModelCandidate& c, bool perspective_first) {
  const bool perspective = lens_type_info(candidate_lens_type(c.name)).family == LensFamily::Perspective;
  return {perspective == perspective_first ? 0 : 1, c.params};
}

// How many splits raced row `x` needs before cannot_change_pick can hold against `pick`:
// all of them when it comes before the pick in the rule's order; else enough that, having
// lost every one of them, it could no longer be better than the pick on most splits in the
// statistic it has won more often so far. Fewer could not stop it, so the race refits that
// many in one round (the two cores share them) instead of one split a round. A rational row
// that has won a split takes all of them: it went on to (nearly) every split on stereo and
// Fisheye190deg, one round at a time, and each round ended on one long refit with the other
// core idle; its refits cost a fifth of the spline's, so one more split is cheaper than a
// round (paired: Fisheye190deg 0.96 of the time, stereo 0.98). The pick is the same either way.
size_t splits_before_it_can_stop(const ModelCandidate& x, const ModelCandidate& pick, size_t splits,
                                 bool perspective_first) {
  const size_t m = x.cross_validation_splits_px.size();
  if (!(rule_rank(pick, perspective_first) < rule_rank(x, perspective_first))) return splits;
  size_t better_heldout = 0, better_cv = 0;
  for (size_t k = 0; k < m; ++k) {
    better_heldout += x.heldout_splits_px[k] < pick.heldout_splits_px[k];
    better_cv += x.cross_validation_splits_px[k] < pick.cross_validation_splits_px[k];
  }
  if (candidate_lens_type(x.name) == LensType::OpenCV8 && std::max(better_heldout, better_cv) > 0) return splits;
  // better + (splits - m') <= splits / 2  <=>  m' >= better + splits - splits / 2
  const size_t needed = std::max(better_heldout, better_cv) + splits - splits / 2;
  return std::min(splits, std::max(m + 1, needed));
}

// Who may be picked: a fit of every view and of the odd/even halves that a lens model can
// have (fit_max_*). Not the repeated value against fit_max_cross_validation_px: with halves
// of 2 views one split of a good model can be 9 px off (190 deg lens, 4 views), and weighing
// such a split against the others is the challenge's job.
std::vector<char> eligible_rows(const std::vector<ModelCandidate>& table, const SelectionOptions& o) {
  std::vector<char> eligible(table.size(), 0);
  for (size_t i = 0; i < table.size(); ++i)
    eligible[i] = table[i].ok && table[i].rms_px <= o.fit_max_rms_px &&
                  table[i].cross_validation_px <= o.fit_max_cross_validation_px;
  return eligible;
}

// The cross-validation repeated over the splits for every candidate that can matter (the
// first split, odd/even, is the table's, fitted cold); true when some candidate got a
// finite repeated value. With `race` (the incumbent rule, at least 3 splits), a raced_type
// candidate is refitted on the second split first, then on more (splits_before_it_can_stop
// a round) while it could change the pick among the candidates with every split
// (cannot_change_pick): the same pick, at fewer warm refits than 2 (K - 1) for a rich model
// that loses. Such a row keeps the splits it has, is raced_out, and has no repeated value.
bool repeat_over_splits(const CalibrationProblem& pr, CandidateFits& fits, std::vector<ModelCandidate>& table,
                        const std::vector<std::vector<int>>& splits, double best_odd_even, bool race,
                        const std::vector<char>& eligible, bool perspective_first, const SelectionOptions& o,
                        const StageProgress& progress) {
  if (splits.size() <= 1) return false;
  const size_t K = splits.size();
  std::vector<size_t> repeat;
  for (size_t i = 0; i < table.size(); ++i) {
    const ModelCandidate& c = table[i];
    if (c.ok && c.cross_validation_px <= o.fit_max_cross_validation_px &&
        c.cross_validation_px <= o.screen_factor * best_odd_even + o.floor_px)
      repeat.push_back(i);
  }
  report_progress(progress, "repeated splits", 0, 1);
  std::vector<std::pair<size_t, size_t>> first;
  for (size_t r : repeat) {
    ModelCandidate& c = table[r];
    c.cross_validation_splits_px = {c.cross_validation_px};
    c.heldout_splits_px = {c.heldout_rms_px};
    first.push_back({r, race && raced_type(candidate_lens_type(c.name)) ? 2 : K});
  }
  extend_over_splits(pr, fits, table, splits, first, o.parallel);
  // Until every raced row left unfinished cannot change the pick of the finished ones. The
  // rule counts the splits of the longest rows: without a row fitted on every split (every
  // other one failed a split), a raced row completed would change what the rule compares,
  // so then every row is completed.
  while (race) {
    const bool some_complete = std::any_of(repeat.begin(), repeat.end(), [&](size_t r) {
      return table[r].cross_validation_splits_px.size() == K;
    });
    if (!some_complete) {
      std::vector<std::pair<size_t, size_t>> all;
      for (size_t r : repeat) all.push_back({r, K});
      extend_over_splits(pr, fits, table, splits, all, o.parallel);
      break;
    }
    std::vector<ModelCandidate> trial = table;
    const size_t pick = incumbent_pick(trial, eligible, perspective_first, o);
    std::vector<std::pair<size_t, size_t>> more;
    for (size_t r : repeat)
      if (!splits_finished(table[r], K) &&
          (pick >= table.size() || !cannot_change_pick(table[r], table, pick, K, perspective_first, o)))
        more.push_back({r, pick >= table.size() ? table[r].cross_validation_splits_px.size() + 1
                                                : splits_before_it_can_stop(table[r], table[pick], K, perspective_first)});
    if (more.empty()) break;
    extend_over_splits(pr, fits, table, splits, more, o.parallel);
  }
  bool repeated = false;
  for (size_t r : repeat) {
    ModelCandidate& c = table[r];
    c.raced_out = !splits_finished(c, K);
    c.cross_validation_repeated_px = c.raced_out ? kNaN : rms_over_splits(c.cross_validation_splits_px);
    if (std::isfinite(c.cross_validation_repeated_px)) repeated = true;
  }
  return repeated;
}

// The noise of a cross-validation: a jackknife standard error of the best model's. Each
// view is left out of its half in turn (that half refitted warm, the other kept); as the two
// halves are independent samples, Var = sum over halves of (m_h - 1) * s_h^2 (the two-sample
// jackknife), with s_h a robust spread (1.4826 MAD) of that half's values so that one
// influential view does not make every model "within noise". NaN with < 3 refits per half.
double cross_validation_noise(const CalibrationProblem& pr, CandidateFits& fits, LensType best, bool parallel,
                              const StageProgress& progress) {
  report_progress(progress, "noise jackknife", 0, 1);
  // One warm refit per view, on every core; NaN where it failed.
  std::vector<double> cv(fits.used.size(), kNaN);
  // Each half's rays, unprojected once for the other half's refits (projection_difference.h).
  GridRays half_rays[2];
  const bool both_ok = fits.halves[0].get(best).ok && fits.halves[1].get(best).ok;
  if (both_ok)
    run_jobs(2, [&](size_t h) { half_rays[h] = grid_rays(fits.halves[h].get(best).model, fits.mask, fits.step); },
             parallel ? 0 : 1);
  run_jobs(fits.used.size(), [&](size_t i) {
    const int h = int(i % 2), pos = int(i / 2);
    ViewSubset rest;
    for (size_t j = 0; j < fits.half[h].size(); ++j)
      if (int(j) != pos) rest.push_back(fits.half[h][j]);
    const ModelFit& from = fits.halves[h].get(best);
    std::vector<BoardPose> poses;
    for (size_t j = 0; j < from.poses.size(); ++j)
      if (int(j) != pos) poses.push_back(from.poses[j]);
    const ModelFit refit = warm_refit(pr, rest, best, from, poses);
    if (!refit.ok) return;
    const CameraModel& other = fits.halves[1 - h].get(best).model;
    const ProjectionDiff d = both_ok ? projection_difference(refit.model, other, half_rays[1 - h])
                                     : projection_difference(refit.model, other, fits.mask, fits.step);
    if (d.samples > 0) cv[i] = d.rms_px;
  }, parallel ? 0 : 1);
  std::vector<double> cvs[2];
  for (size_t i = 0; i < cv.size(); ++i)
    if (!std::isnan(cv[i])) cvs[i % 2].push_back(cv[i]);
  if (cvs[0].size() < 3 || cvs[1].size() < 3) return kNaN;
  double var = 0;
  for (const auto& v : cvs) {
    const double med = median_of(v);
    std::vector<double> dev;
    for (double c : v) dev.push_back(std::abs(c - med));
    const double sh = 1.4826 * median_of(dev);
    var += double(v.size() - 1) * sh * sh;
  }
  return std::sqrt(var);
}

// Sample SD / sqrt(K) of the per-split values; NaN with fewer than 2.
double split_noise(const std::vector<double>& v) {
  if (v.size() < 2) return kNaN;
  const double mean = std::accumulate(v.begin(), v.end(), 0.0) / double(v.size());
  double ss = 0;
  for (double x : v) ss += (x - mean) * (x - mean);
  return std::sqrt(ss / double(v.size() - 1)) / std::sqrt(double(v.size()));
}

// The pick: fewest parameters among the candidates within the noise of `best` (see the
// header and SelectionOptions::k); marks within_noise.
size_t pick_within_noise(const CandidateFits& fits, std::vector<ModelCandidate>& table, size_t best, double noise,
                         const std::function<double(const ModelCandidate&)>& score, const SelectionOptions& o) {
  // The held-out RMS (each half's model on the other half's corners, poses re-solved) is a
  // far more precise statistic than a cross-validation (a mean over every corner, relative
  // standard error ~1 / sqrt(2 n) over n residual components, and the same corners for every
  // candidate): a model whose held-out error is significantly above the best's misses the
  // corners, however noisy the cross-validation. Not the full fit's RMS: it falls with every
  // parameter added, so once the best could be the 100-parameter spline (ranked on 4 splits,
  // Ladybug: RMS 0.182 against Kannala-Brandt's 0.224, held-out 0.232 against 0.228) it
  // disqualified every parametric model.
  int components = 0;
  for (const BoardView* v : fits.used) components += 2 * int(std::count(v->inlier.begin(), v->inlier.end(), 1));
  const double heldout_limit = table[best].heldout_rms_px * (1 + o.k / std::sqrt(double(std::max(1, components))));
  const double best_score = score(table[best]);
  for (auto& c : table)
    c.within_noise = c.ok && c.cross_validation_px <= o.fit_max_cross_validation_px &&
                     score(c) <= o.fit_max_cross_validation_px && score(c) - best_score <= o.k * noise + o.floor_px &&
                     c.heldout_rms_px <= heldout_limit;
  size_t pick = best;
  for (size_t i = 0; i < table.size(); ++i) {
    const ModelCandidate& c = table[i];
    if (c.ok && c.within_noise &&
        (c.params < table[pick].params || (c.params == table[pick].params && score(c) < score(table[pick]))))
      pick = i;
  }
  return pick;
}

// Student's t, 97.5 % quantile, for `dof` degrees of freedom (1.96 beyond 30).
double t975(int dof) {
  static const double t[] = {12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228,
                             2.201,  2.179, 2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086,
                             2.080,  2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045, 2.042};
  return dof < 1 ? kInf : dof <= 30 ? t[dof - 1] : 1.96;
}

// Mean and standard error (sample SD / sqrt(n)) of a[k] - b[k].
std::pair<double, double> paired_mean_se(const std::vector<double>& a, const std::vector<double>& b) {
  const size_t n = a.size();
  double mean = 0, ss = 0;
  for (size_t k = 0; k < n; ++k) mean += (a[k] - b[k]) / double(n);
  for (size_t k = 0; k < n; ++k) ss += (a[k] - b[k] - mean) * (a[k] - b[k] - mean);
  return {mean, n > 1 ? std::sqrt(ss / double(n - 1) / double(n)) : kInf};
}

bool all_finite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

// How far off the axis the boards were seen: the largest angle of a used inlier corner's
// ray, unprojected through the eligible candidate with the lowest held-out RMS (NaN: none).
double observed_field_deg(const CandidateFits& fits, const std::vector<ModelCandidate>& table,
                          const std::vector<char>& eligible) {
  const ModelCandidate* ref = nullptr;
  for (size_t i = 0; i < table.size(); ++i)
    if (eligible[i] && (!ref || table[i].heldout_rms_px < ref->heldout_rms_px)) ref = &table[i];
  if (!ref) return kNaN;
  return corner_field_deg(ref->model, fits.used);
}

}  // namespace

bool outfits_over_splits(const SplitValues& better, const SplitValues& worse, double factor) {
  const size_t splits = better.heldout_px.size();
  if (splits == 0 || worse.heldout_px.size() != splits || better.cross_validation_px.size() != splits ||
      worse.cross_validation_px.size() != splits)
    return false;
  int cv_not_worse = 0;
  for (size_t k = 0; k < splits; ++k) {
    if (!(factor * better.heldout_px[k] < worse.heldout_px[k])) return false;
    cv_not_worse += better.cross_validation_px[k] <= worse.cross_validation_px[k];
  }
  return 2 * cv_not_worse >= int(splits);
}

bool cannot_change_pick(const ModelCandidate& x, const std::vector<ModelCandidate>& table, size_t pick,
                        size_t splits, bool perspective_first, const SelectionOptions& o) {
  const ModelCandidate& p = table[pick];
  const size_t m = x.cross_validation_splits_px.size();
  if (!(rule_rank(p, perspective_first) < rule_rank(x, perspective_first))) return false;
  const auto can_win_most = [&](const std::vector<double>& a, const std::vector<double>& b) {
    size_t better = 0;
    for (size_t k = 0; k < m; ++k) better += a[k] < b[k];
    return 2 * (better + splits - m) > splits;
  };
  if (can_win_most(x.heldout_splits_px, p.heldout_splits_px) ||
      can_win_most(x.cross_validation_splits_px, p.cross_validation_splits_px))
    return false;
  if (o.outfit_factor < 1) return true;
  // Outfitting takes a candidate out of the rule. That can change the pick only when it is
  // the pick, or beats a candidate up to the pick (it may be what kept that one from being
  // picked); ties of the order counted as either side.
  const auto rank = [&](const ModelCandidate& c) { return rule_rank(c, perspective_first); };
  const auto complete = [&](const ModelCandidate& c) {
    return &c != &x && c.heldout_splits_px.size() == splits && c.cross_validation_splits_px.size() == splits;
  };
  const auto may_matter = [&](const ModelCandidate& y) {
    if (&y == &p) return true;
    for (const ModelCandidate& z : table)
      if (&z != &y && complete(z) && !(rank(p) < rank(z)) && !(rank(y) < rank(z)) &&
          challenge_over_splits({y.heldout_splits_px, y.cross_validation_splits_px},
                                {z.heldout_splits_px, z.cross_validation_splits_px}, o)
              .wins)
        return true;
    return false;
  };
  for (const ModelCandidate& y : table) {
    if (!complete(y)) continue;
    bool lower_on_every = true;
    for (size_t k = 0; k < m && lower_on_every; ++k)
      lower_on_every = o.outfit_factor * x.heldout_splits_px[k] < y.heldout_splits_px[k];
    if (lower_on_every && may_matter(y)) return false;
  }
  return true;
}

SplitChallenge challenge_over_splits(const SplitValues& challenger, const SplitValues& incumbent,
                                     const SelectionOptions& o) {
  SplitChallenge r;
  const size_t splits = challenger.heldout_px.size();
  if (splits < 2 || incumbent.heldout_px.size() != splits || challenger.cross_validation_px.size() != splits ||
      incumbent.cross_validation_px.size() != splits)
    return r;
  // The paired gains (the incumbent's value minus the challenger's, per split). The
  // challenger wins when it is better on most splits and on average beyond the noise in one
  // statistic, and not significantly worse in the other.
  std::tie(r.gain_px, r.se_px) = paired_mean_se(incumbent.heldout_px, challenger.heldout_px);
  std::tie(r.cv_gain_px, r.cv_se_px) = paired_mean_se(incumbent.cross_validation_px, challenger.cross_validation_px);
  for (size_t k = 0; k < splits; ++k) {
    r.better += challenger.heldout_px[k] < incumbent.heldout_px[k];
    r.cv_better += challenger.cross_validation_px[k] < incumbent.cross_validation_px[k];
  }
  const double t = t975(int(splits) - 1);
  const bool fits_better =
      2 * r.better > int(splits) && r.gain_px > t * r.se_px && -r.cv_gain_px <= t * r.cv_se_px + o.floor_px;
  const bool repeats_better =
      2 * r.cv_better > int(splits) && r.cv_gain_px > t * r.cv_se_px && -r.gain_px <= t * r.se_px;
  r.wins = fits_better || repeats_better;
  return r;
}

size_t incumbent_pick(std::vector<ModelCandidate>& table, const std::vector<char>& eligible, bool perspective_first,
                      const SelectionOptions& o) {
  // Who takes part: every split fitted, the same number of splits (they are the same splits).
  size_t splits = 0;
  for (const auto& c : table) splits = std::max(splits, c.heldout_splits_px.size());
  std::vector<size_t> order;
  for (size_t i = 0; i < table.size(); ++i) {
    const ModelCandidate& c = table[i];
    if (eligible[i] && splits >= size_t(std::max(2, o.min_rule_splits)) && c.heldout_splits_px.size() == splits &&
        c.cross_validation_splits_px.size() == splits && all_finite(c.heldout_splits_px) &&
        all_finite(c.cross_validation_splits_px))
      order.push_back(i);
  }
  for (auto& c : table) {
    c.split_wins = 0;
    c.outfitted = false;
    c.challenge_gain_px = c.challenge_se_px = c.challenge_cv_gain_px = c.challenge_cv_se_px = kNaN;
  }
  if (order.empty()) return table.size();
  // Systematically outfitted candidates leave (see SelectionOptions::outfit_factor). With a
  // factor >= 1 "outfits" is a strict order (no cycle), so some candidate always stays.
  if (o.outfit_factor >= 1) {
    const auto outfits = [&](const ModelCandidate& d, const ModelCandidate& c) {
      return outfits_over_splits({d.heldout_splits_px, d.cross_validation_splits_px},
                                 {c.heldout_splits_px, c.cross_validation_splits_px}, o.outfit_factor);
    };
    std::vector<size_t> kept;
    for (size_t i : order) {
      table[i].outfitted = std::any_of(order.begin(), order.end(), [&](size_t d) { return d != i && outfits(table[d], table[i]); });
      if (!table[i].outfitted) kept.push_back(i);
    }
    order = std::move(kept);
  }
  // The vote: who fits the held-out corners best on each split (reported; the rule below
  // asks for a majority of the splits against the incumbent, not of all candidates).
  for (size_t k = 0; k < splits; ++k) {
    size_t w = order[0];
    for (size_t i : order)
      if (table[i].heldout_splits_px[k] < table[w].heldout_splits_px[k]) w = i;
    table[w].split_wins++;
  }
  // The lens's own family first, simplest first within it (on equal parameter counts, the
  // lower repeated cross-validation).
  const auto rank = [&](size_t i) {
    const bool perspective = lens_type_info(candidate_lens_type(table[i].name)).family == LensFamily::Perspective;
    return perspective == perspective_first ? 0 : 1;
  };
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (rank(a) != rank(b)) return rank(a) < rank(b);
    if (table[a].params != table[b].params) return table[a].params < table[b].params;
    return rms_over_splits(table[a].cross_validation_splits_px) < rms_over_splits(table[b].cross_validation_splits_px);
  });
  const auto challenge = [&](const ModelCandidate& c, const ModelCandidate& a) {
    return challenge_over_splits({c.heldout_splits_px, c.cross_validation_splits_px},
                                 {a.heldout_splits_px, a.cross_validation_splits_px}, o);
  };
  const auto beats = [&](size_t c, size_t a) { return challenge(table[order[c]], table[order[a]]).wins; };
  // The pick: the first candidate, in that order, that no candidate after it beats. Not the
  // last winner of a chain of challenges: there the pick depended on the order of the
  // challengers (Fisheye190deg's half of 4 views: Mei beat the stereographic first incumbent,
  // so Kannala-Brandt, which Mei does not beat and which one diverged split kept from beating
  // the stereographic model itself, was never compared with Mei; the two halves then chose
  // Mei and Kannala-Brandt and agreed to 2.0 px against 0.15 for Kannala-Brandt on both).
  const auto beaten_by_a_later_one = [&](size_t j) {
    for (size_t i = j + 1; i < order.size(); ++i)
      if (beats(i, j)) return true;
    return false;
  };
  size_t pick = 0;  // the last candidate has none after it: there always is one
  while (beaten_by_a_later_one(pick)) ++pick;
  // Reported: every other candidate's comparison with the pick.
  for (size_t j = 0; j < order.size(); ++j) {
    if (j == pick) continue;
    ModelCandidate& c = table[order[j]];
    const SplitChallenge r = challenge(c, table[order[pick]]);
    c.challenge_gain_px = r.gain_px, c.challenge_se_px = r.se_px;
    c.challenge_cv_gain_px = r.cv_gain_px, c.challenge_cv_se_px = r.cv_se_px;
  }
  return order[pick];
}

CandidateFits::CandidateFits(const CalibrationProblem& pr, ViewSubset used_views)
    : used(std::move(used_views)),
      half{half_of(used, 0), half_of(used, 1)},
      mask(coverage_mask(pr, used)),
      step(auto_step(pr)),
      full(pr, used),
      halves{CandidateSolver(pr, half[0]), CandidateSolver(pr, half[1])} {}

std::vector<ModelCandidate> solve_candidates(const CalibrationProblem& pr, CandidateFits& fits,
                                             const std::vector<LensType>& candidates, const CandidateOptions& o,
                                             const StageProgress& progress) {
  report_progress(progress, "candidates", 0, 3);
  // Many views: one short solve of each candidate on a sample first; a model that misses
  // even those corners by far is not fitted on every view (see CandidateOptions).
  std::vector<LensType> fitted = candidates;
  std::vector<LensType> fit_the_sample;  // fitted the odd half within screen_rms_px
  std::map<LensType, ModelCandidate> on_sample;
  // The sample: sample_views evenly spaced views of a large set, else the odd half, whose
  // cold fits the halves' stage reuses (a kept candidate costs nothing more; a screened one
  // half its full fit).
  const bool large = fits.used.size() >= 2 * size_t(std::max(4, o.sample_views));
  const bool on_half = !large && o.min_half_sample_views > 0 && fits.half[1].size() >= size_t(o.min_half_sample_views);
  std::optional<CandidateSolver> own_sample;
  if (large) {
    own_sample.emplace(pr, evenly_spaced(fits.used, size_t(std::max(4, o.sample_views))));
    // A candidate already fitted on every view (the outlier stage's reference, carried) is
    // refitted on the sample warm from that fit: the same minimum, for screening, without its
    // cold solve (synthetic 32 views: Kannala-Brandt's cv::fisheye seed and Ceres, 0.2 s).
    const ViewSubset& sample = own_sample->views();
    for (LensType type : candidates)
      if (const ModelFit* f = fits.full.solved(type); f && f->ok) {
        std::vector<BoardPose> poses;
        for (const BoardView* v : sample)
          poses.push_back(f->poses[size_t(std::find(fits.used.begin(), fits.used.end(), v) - fits.used.begin())]);
        ModelFit w = warm_refit(pr, sample, type, *f, poses);
        w.solver = f->solver + ", refitted warm on the sample";  // a screened row's table[].solver
        own_sample->adopt(type, std::move(w));
      }
  }
  CandidateSolver* sampled = large ? &*own_sample : on_half ? &fits.halves[1] : nullptr;
  if (std::isfinite(o.screen_rms_px) && sampled) {
    const ViewSubset& sample = sampled->views();
    // A perspective candidate's job first asks for the wide-angle fits' field (solving them if
    // no other job has), and fits only where it can image the corners.
    std::vector<SolveJob> jobs;
    for (LensType type : candidates) jobs.push_back({sampled, type});
    std::vector<char> out_of_field(candidates.size(), 0);
    // Only where the wide fits are candidates too (they are solved on this sample anyway):
    // a list of perspective models alone fits no Mei for the question.
    const auto has = [&](LensType t) { return std::find(candidates.begin(), candidates.end(), t) != candidates.end(); };
    const bool gate = std::isfinite(o.perspective_field_limit_deg) && has(LensType::KannalaBrandt) &&
                      has(LensType::OmnidirMei);
    WideField field;
    std::mutex field_mutex;
    // With the gate, the wide candidates start first: a perspective job waits for the gate's
    // Kannala-Brandt and Mei fits, and in start_rank order it held a core while another solved
    // them (MiniOmni: 56 ms idle while Kannala-Brandt failed on the other; the stereographic
    // and spline fits, which need only Mei's, queued behind). Paired, 8 runs each: MiniOmni
    // 0.954 of the wall time, fisheye1 0.973, VMRImage 0.979, stereo 0.985, and 1.000-1.006 on
    // Ladybug, KaidanOmni, Fisheye190deg and 16 synthetic views.
    std::stable_sort(jobs.begin(), jobs.end(), [&](const SolveJob& a, const SolveJob& b) {
      if (gate && is_perspective(a.second) != is_perspective(b.second)) return is_perspective(b.second);
      return start_rank(a.second) < start_rank(b.second);
    });
    run_jobs(jobs.size(), [&](size_t i) {
      const LensType type = jobs[i].second;
      if (gate && is_perspective(type)) {
        const WideField w = wide_fit_field(pr, *sampled, o.screen_rms_px);
        if (w.deg > o.perspective_field_limit_deg) {
          const std::lock_guard lock(field_mutex);
          field = w;
          out_of_field[size_t(std::find(candidates.begin(), candidates.end(), type) - candidates.begin())] = 1;
          return;
        }
      }
      sampled->get(type);
    }, o.parallel ? 0 : 1);
    double best = kInf;
    for (size_t i = 0; i < candidates.size(); ++i)
      if (!out_of_field[i])
        if (const ModelFit& f = sampled->get(candidates[i]); f.ok) best = std::min(best, fit_rms(pr, f, sample));
    if (best <= o.screen_rms_px) {  // else nothing fits the sample: every candidate on every view
      fitted.clear();
      for (size_t i = 0; i < candidates.size(); ++i) {
        const LensType type = candidates[i];
        if (out_of_field[i]) {
          ModelCandidate& c = on_sample[type];
          c.name = candidate_name(type);
          c.lensmodel = lens_type_name(type);
          if (const auto lens = LensModel::try_parse(c.lensmodel)) c.params = lens->param_count();
          c.rms_px = kNaN;
          c.screened = true;
          c.error = fmt_out_of_field(field, sample.size(), fits.used.size(), o.perspective_field_limit_deg);
          continue;
        }
        const ModelFit& f = sampled->get(type);
        const double rms = f.ok ? fit_rms(pr, f, sample) : kInf;
        if (!f.ok || rms <= o.sample_margin * o.screen_rms_px) {
          fitted.push_back(type);
          if (on_half && rms <= o.screen_rms_px) fit_the_sample.push_back(type);
          continue;
        }
        ModelCandidate& c = on_sample[type];
        c.name = candidate_name(type);
        c.lensmodel = f.model.lensmodel;
        c.solver = f.solver;
        c.params = f.params;
        c.rms_px = rms;
        c.screened = true;
        char buf[200];
        std::snprintf(buf, sizeof buf,
                      "screened out: RMS %.3f px on %zu of the %zu views, above %.3g x %.3g px; not fitted on all", rms,
                      sample.size(), fits.used.size(), o.sample_margin, o.screen_rms_px);
        c.error = buf;
      }
    }
  }
  // A large set's full fits seed on the same evenly spaced views as the sample (SeedOptions::
  // sample_views): they start from its fits instead of solving them again.
  if (own_sample) fits.full.reuse_sample_fits(*own_sample);
  report_progress(progress, "candidates", 1, 3);
  // Each row (the halves' projection difference and held-out RMS) is made by the job that
  // completes its candidate's fits, beside the other solves, not after the last of them: the
  // rows, one core each (the rational model's unprojects every grid pixel), waited for the
  // stage's longest solve while the other core idled (stereo: the spline's 40 ms tail, then
  // 17 ms of rows). A candidate whose own RMS is within screen_rms_px is kept whatever the
  // others' (`screen` below is screen_rms_px or infinite), so its row can be made at once.
  const auto row_of = [&](LensType t) {
    return size_t(std::find(candidates.begin(), candidates.end(), t) - candidates.begin());
  };
  std::vector<ModelCandidate> table(candidates.size());
  std::vector<char> made(candidates.size(), 0);
  std::unique_ptr<std::atomic<int>[]> fits_left(new std::atomic<int>[candidates.size()]);
  const auto run_fits = [&](std::vector<SolveJob> jobs, const std::function<void(LensType)>& fitted_one) {
    std::stable_sort(jobs.begin(), jobs.end(),
                     [](const SolveJob& a, const SolveJob& b) { return start_rank(a.second) < start_rank(b.second); });
    run_jobs(jobs.size(), [&](size_t j) {
      jobs[j].first->get(jobs[j].second);
      fitted_one(jobs[j].second);
    }, o.parallel ? 0 : 1);
  };
  // The full fits, so that the screening knows which halves to fit; beside them the even
  // half of a candidate that fitted the odd one within screen_rms_px (it will hardly be
  // screened, and the cores do not wait for the slowest full fit before the halves start).
  std::vector<SolveJob> jobs;
  for (size_t i = 0; i < candidates.size(); ++i) fits_left[i] = 0;
  for (LensType type : fitted) jobs.push_back({&fits.full, type});
  for (LensType type : fit_the_sample) {
    jobs.push_back({&fits.halves[0], type});
    fits_left[row_of(type)] = 2;  // the full fit and the even half; the odd one is the sample's
  }
  // (A candidate fitted on every view only counts below zero here: its halves come later.)
  run_fits(std::move(jobs), [&](LensType type) {
    const size_t i = row_of(type);
    if (fits_left[i].fetch_sub(1, std::memory_order_acq_rel) != 1) return;
    if (const ModelFit& f = fits.full.get(type); f.ok && fit_rms(pr, f, fits.used) <= o.screen_rms_px) {
      table[i] = evaluate(pr, fits, type, o.screen_rms_px, o.parallel);
      made[i] = 1;
    }
  });
  double best_rms = kInf;
  for (LensType type : fitted)
    if (const ModelFit& f = fits.full.get(type); f.ok) best_rms = std::min(best_rms, fit_rms(pr, f, fits.used));
  // No candidate fits: nothing is screened (the least bad one is still ranked on its halves).
  const double screen = best_rms <= o.screen_rms_px ? o.screen_rms_px : kInf;
  report_progress(progress, "candidates", 2, 3);
  // The other kept candidates' halves; a row made when its second half is fitted.
  std::vector<SolveJob> halves;
  for (LensType type : fitted)
    if (const ModelFit& f = fits.full.get(type); f.ok && fit_rms(pr, f, fits.used) <= screen && !made[row_of(type)]) {
      for (CandidateSolver* h : {&fits.halves[0], &fits.halves[1]}) halves.push_back({h, type});
      fits_left[row_of(type)] = 2;
    }
  run_fits(std::move(halves), [&](LensType type) {
    const size_t i = row_of(type);
    if (fits_left[i].fetch_sub(1, std::memory_order_acq_rel) != 1) return;
    table[i] = evaluate(pr, fits, type, screen, o.parallel);
    made[i] = 1;
  });
  run_jobs(candidates.size(), [&](size_t i) {
    if (made[i]) return;
    const auto it = on_sample.find(candidates[i]);
    table[i] = it != on_sample.end() ? it->second : evaluate(pr, fits, candidates[i], screen, o.parallel);
  }, o.parallel ? 0 : 1);
  // A fit of every view worse than each half's model on the other half's views (held out)
  // stopped short: the half-models show a better one exists. It is refitted on every view
  // from the better half-model (every view posed under it), and kept with its row made again
  // where that fits better. An audit's 125 deg rational lens: 0.769 px RMS against 0.278 held
  // out, 35 px from the truth. After the parallel jobs: no other thread reads the fits now.
  for (size_t i = 0; i < candidates.size(); ++i) {
    ModelCandidate& c = table[i];
    if (!c.ok || c.screened || !(c.rms_px > kStoppedShortFactor * c.heldout_rms_px)) continue;
    const LensType type = candidates[i];
    const ModelFit* full = fits.full.solved(type);
    if (!full || !full->ok) continue;
    std::optional<ModelFit> better;
    double better_rms = c.rms_px;
    for (CandidateSolver* half : {&fits.halves[0], &fits.halves[1]}) {
      const ModelFit* h = half->solved(type);
      if (!h || !h->ok) continue;
      std::vector<BoardPose> poses;
      for (const BoardView* v : fits.used)
        if (const auto p = solve_pose(pr, h->model, h->warp, *v)) poses.push_back(*p);
      if (poses.size() != fits.used.size()) continue;
      ModelFit g = warm_refit(pr, fits.used, type, *h, poses);
      if (!g.ok) continue;
      if (const double rms = fit_rms(pr, g, fits.used); rms < better_rms) {
        better_rms = rms;
        g.solver = full->solver + ", refitted from a half's model (" + px3(c.rms_px) + " px before)";
        better = std::move(g);
      }
    }
    if (!better) continue;
    fits.full.replace(type, std::move(*better));
    // The board warp decision's split refits started from the old fit: refitted anew.
    if (fits.known_splits && fits.known_splits->type == type) fits.known_splits.reset();
    c = evaluate(pr, fits, type, screen, o.parallel);
  }
  return table;
}

SelectionReport select_model(const CalibrationProblem& pr, CandidateFits& fits, std::vector<ModelCandidate>& table,
                             const SelectionOptions& o, const StageProgress& progress) {
  SelectionReport rep;
  // Fewest parameters within the noise of the best cross-validation, ranked on the
  // cross-validation repeated over o.cv_splits balanced splits (one split is one noisy draw:
  // it scattered by ~2x between noise draws of one setup).
  // Among the candidates whose half-models can pose the other half's views, where there are
  // any: where no candidate fitted, a plumb_bob whose halves could not (5.6 px apart, the
  // others 8-57) was the least bad by its cross-validation, written 49 px from the truth.
  const bool some_held_out = std::any_of(table.begin(), table.end(), [](const ModelCandidate& c) {
    return c.ok && std::isfinite(c.heldout_rms_px);
  });
  const ModelCandidate* best_odd_even = nullptr;
  for (const auto& c : table)
    if (c.ok && (std::isfinite(c.heldout_rms_px) || !some_held_out) &&
        (!best_odd_even || c.cross_validation_px < best_odd_even->cross_validation_px))
      best_odd_even = &c;
  if (!best_odd_even) {
    std::string why;
    for (const auto& c : table) why += (why.empty() ? "" : "; ") + c.name + ": " + c.error;
    throw InputError("calibrate: no candidate model could be fitted (" + why + ")");
  }
  const int splits = o.cv_splits > 1 && int(fits.used.size()) <= o.small_set_views
                         ? std::max(o.cv_splits, o.small_set_cv_splits)
                         : o.cv_splits;
  rep.splits = balanced_view_splits(int(fits.used.size()), std::max(1, splits));
  // The incumbent rule's eligibility and order depend on the odd/even fits only: known
  // before the repeated splits, which the race needs.
  const std::vector<char> eligible = eligible_rows(table, o);
  const bool incumbent = o.rule == SelectionRule::Incumbent;
  if (incumbent) {
    rep.field_deg = observed_field_deg(fits, table, eligible);
    rep.perspective_first = rep.field_deg <= o.perspective_field_deg;
  }
  const bool race = incumbent && o.race_dear_candidates && rep.splits.size() >= size_t(std::max(3, o.min_rule_splits));
  const bool repeated = repeat_over_splits(pr, fits, table, rep.splits, best_odd_even->cross_validation_px, race,
                                           eligible, rep.perspective_first, o, progress);
  rep.selected_on = repeated ? "repeated" : "odd/even";
  rep.cv_splits = repeated ? int(rep.splits.size()) : 1;
  const auto score = [&](const ModelCandidate& c) {
    if (!c.ok) return kInf;
    if (!repeated) return c.cross_validation_px;
    return std::isfinite(c.cross_validation_repeated_px) ? c.cross_validation_repeated_px : kInf;
  };
  size_t best = size_t(best_odd_even - table.data());
  if (repeated) {
    bool found = false;
    for (size_t i = 0; i < table.size(); ++i)
      if (std::isfinite(score(table[i])) && (std::isfinite(table[i].heldout_rms_px) || !some_held_out) &&
          (!found || score(table[i]) < score(table[best]))) {
        best = i;
        found = true;
      }
    rep.cv_split_noise_px = split_noise(table[best].cross_validation_splits_px);
  }
  // Only the selection uses the jackknife noise: skipped (NaN) when the model is forced.
  if (o.measure_noise)
    rep.cv_noise_px = cross_validation_noise(pr, fits, candidate_lens_type(table[best].name), o.parallel, progress);
  // The tolerance. The K-split mean scatters less than one split, by up to sqrt(K) (less:
  // the splits share the views, and the data's own noise is common to all of them), so the
  // odd/even jackknife SE is a conservative bound on its noise; the per-split spread /
  // sqrt(K) measures only the split-to-split part, from K values. docs/calibration.md
  // ("Model selection uses the measured noise") has the measurement that chose the default.
  const bool from_splits = o.noise_from_splits && std::isfinite(rep.cv_split_noise_px);
  const double noise_used = from_splits ? rep.cv_split_noise_px : rep.cv_noise_px;
  rep.noise_px = std::isfinite(noise_used) ? noise_used : 0.0;
  rep.k = o.k;
  rep.noise_from_splits = from_splits;
  rep.simplest_within_noise = pick_within_noise(fits, table, best, rep.noise_px, score, o);
  rep.selected = rep.simplest_within_noise;
  rep.rule = "simplest within noise";
  if (incumbent) {
    const size_t pick = incumbent_pick(table, eligible, rep.perspective_first, o);
    if (pick < table.size()) {
      rep.selected = pick;
      rep.rule = "incumbent";
    }
  }
  rep.no_model_fits = true;
  for (const auto& c : table)
    if (c.ok && c.rms_px <= o.fit_max_rms_px && c.cross_validation_px <= o.fit_max_cross_validation_px)
      rep.no_model_fits = false;
  return rep;
}

// A split that follows the capture order (first/second half) would put the central boards
// in one half and the rim in the other and measure coverage, not noise: odd/even first, then
// pseudo-random ones (deterministic).
std::vector<std::vector<int>> balanced_view_splits(int n, int k) {
  std::vector<std::vector<int>> out;
  std::vector<int> side(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) side[size_t(i)] = i % 2;
  out.push_back(side);
  std::mt19937 rng(12345);
  for (int tries = 0; int(out.size()) < k && tries < 100 * k; ++tries) {
    for (int i = n - 1; i > 0; --i) std::swap(side[size_t(i)], side[size_t(rng() % uint32_t(i + 1))]);
    const bool seen = std::any_of(out.begin(), out.end(), [&](const std::vector<int>& s) {
      bool same = true, complement = true;
      for (size_t i = 0; i < s.size(); ++i) {
        same = same && s[i] == side[i];
        complement = complement && s[i] != side[i];
      }
      return same || complement;
    });
    if (!seen) out.push_back(side);
  }
  return out;
}

namespace {

// The two halves of a split: their views, and `full`'s poses of them (aligned); usable
// when both have at least 2 views (the odd/even halves of the smallest set calibrate
// accepts, 4 views, do).
struct SplitSides {
  ViewSubset views[2];
  std::vector<BoardPose> poses[2];
  bool usable() const { return views[0].size() >= 2 && views[1].size() >= 2; }
};
SplitSides split_sides(const ViewSubset& used, const std::vector<int>& side, const ModelFit& full) {
  SplitSides s;
  for (size_t i = 0; i < used.size(); ++i) {
    s.views[side[i]].push_back(used[i]);
    s.poses[side[i]].push_back(full.poses[i]);
  }
  return s;
}

// Both halves of a split refitted warm from `full`; false when a half has < 2 views or
// cannot be fitted.
bool split_halves(const CalibrationProblem& pr, const ViewSubset& used, const std::vector<int>& side, LensType type,
                  const ModelFit& full, ModelFit (&fit)[2]) {
  const SplitSides s = split_sides(used, side, full);
  if (!s.usable()) return false;
  for (int h = 0; h < 2; ++h) {
    fit[h] = warm_refit(pr, s.views[h], type, full, s.poses[h]);
    if (!fit[h].ok) return false;
  }
  return true;
}

}  // namespace

double split_cross_validation(const CalibrationProblem& pr, const ViewSubset& used, const std::vector<int>& side,
                              LensType type, const ModelFit& full, const std::vector<uint8_t>& mask, int step) {
  ModelFit fit[2];
  if (!split_halves(pr, used, side, type, full, fit)) return kInf;
  const ProjectionDiff d = projection_difference(fit[0].model, fit[1].model, mask, step);
  return d.samples > 0 ? d.rms_px : kInf;
}

std::vector<SplitValidation> split_validations(const ViewSubset& used, const std::vector<SplitTask>& tasks,
                                               const std::vector<uint8_t>& mask, int step, bool parallel) {
  struct Half {
    ModelFit fit;
    GridRays rays;  // unprojected beside the refit: the comparison then only projects
    double heldout_px = kInf;
    bool ok = false;
  };
  std::vector<Half> halves(2 * tasks.size());
  std::vector<SplitValidation> values(tasks.size(), SplitValidation{kInf, kInf});
  // Whichever half finishes second compares the two at once: no barrier after the refits,
  // where a round's last long refit left the other core idle and the comparisons then ran
  // after it (Fisheye190deg's rational splits: ~5 ms of one core per round).
  std::unique_ptr<std::atomic<int>[]> finished(new std::atomic<int>[tasks.size()]);
  for (size_t k = 0; k < tasks.size(); ++k) finished[k] = 0;
  run_jobs(halves.size(), [&](size_t q) {
    const size_t k = q / 2;
    const SplitTask& t = tasks[k];
    const int h = int(q % 2);
    const SplitSides s = split_sides(used, *t.side, *t.full);
    Half& out = halves[q];
    if (s.usable()) {
      out.fit = warm_refit(*t.problem, s.views[h], t.type, *t.full, s.poses[h]);
      out.ok = out.fit.ok;
      if (out.ok) {
        out.heldout_px = heldout_rms(*t.problem, out.fit, s.views[1 - h]);
        out.rays = grid_rays(out.fit.model, mask, step);
      }
    }
    if (finished[k].fetch_add(1, std::memory_order_acq_rel) != 1) return;
    const Half& a = halves[2 * k];
    const Half& b = halves[2 * k + 1];
    if (!a.ok || !b.ok) return;
    const ProjectionDiff d = projection_difference(a.rays, b.fit.model, b.rays);
    if (d.samples == 0) return;
    values[k] = {d.rms_px, std::sqrt(0.5 * (a.heldout_px * a.heldout_px + b.heldout_px * b.heldout_px))};
  }, parallel ? 0 : 1);
  return values;
}

double rms_over_splits(const std::vector<double>& v) {
  if (v.empty()) return kNaN;
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s / double(v.size()));
}

}  // namespace lp
