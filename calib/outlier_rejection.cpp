#include "calib/outlier_rejection.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>

#include "calib/calibration_seed.h"
#include "calib/calibration_solve.h"
#include "calib/parallel_jobs.h"
#include "core/error.h"

namespace lp {
namespace {

// The requested model (rational, then pinhole, when it cannot be fitted); else the best of
// options.references on a sample of the views (see the header).
std::optional<LensType> choose_reference(const CalibrationProblem& pr, CandidateSolver& fitter,
                                         const OutlierOptions& options,
                                         const std::vector<std::pair<LensType, ModelFit>>& on_sample) {
  if (options.model) {
    for (LensType r : {*options.model, LensType::OpenCV8, LensType::Pinhole})
      if (fitter.get(r).ok) return r;
    return std::nullopt;
  }
  const ViewSubset sample = evenly_spaced(fitter.views(), size_t(std::max(4, options.reference_views)));
  CandidateSolver sampled(pr, sample);
  CandidateSolver& chooser = sample.size() == fitter.views().size() ? fitter : sampled;
  for (const auto& [type, fit] : on_sample) chooser.adopt(type, fit);  // fitted on this sample already
  // The references' fits on every core (they are independent); the choice below reads them.
  // A perspective reference is not fitted where the wide ones see the sample's corners beyond
  // its reach (OutlierOptions::perspective_field_limit_deg).
  const auto& refs = options.references;
  const bool wide_refs = std::find(refs.begin(), refs.end(), LensType::KannalaBrandt) != refs.end() &&
                         std::find(refs.begin(), refs.end(), LensType::OmnidirMei) != refs.end();
  std::vector<char> out_of_field(options.references.size(), 0);
  run_jobs(options.references.size(), [&](size_t i) {
    const LensType r = options.references[i];
    if (wide_refs && is_perspective(r) && std::isfinite(options.perspective_field_limit_deg) &&
        wide_fit_field(pr, chooser, options.perspective_fit_rms_px).deg > options.perspective_field_limit_deg) {
      out_of_field[i] = 1;
      return;
    }
    chooser.get(r);
  }, options.parallel ? 0 : 1);
  std::optional<LensType> ref;
  double best_rms = std::numeric_limits<double>::infinity();
  std::vector<std::pair<double, LensType>> fitting;  // the sample's RMS of each reference that fits it
  for (size_t i = 0; i < options.references.size(); ++i) {
    if (out_of_field[i]) continue;
    const LensType r = options.references[i];
    const ModelFit& g = chooser.get(r);
    if (!g.ok) continue;
    const double e = fit_rms(pr, g, sample);
    fitting.push_back({e, r});
    if (e < best_rms * (1 - options.reference_tie)) {
      best_rms = e;
      ref = r;
    }
  }
  // The sample is the one a large set's solve seeds on (SeedOptions::sample_views): its fits
  // are those of the solve on every view below.
  if (&chooser == &sampled) fitter.reuse_sample_fits(sampled);
  if (ref && !fitter.get(*ref).ok) ref.reset();  // fits the sample, not all views
  if (!ref) {
    // The next best on the sample that fits every view, then the rest in their order: not
    // the first in the list. An audit's 125 deg rational lens, whose Kannala-Brandt fit of
    // every view failed, fell back to Mei (0.84 px on the sample against the rational
    // model's 0.53) and 108 of its 770 noise-only corners were called outliers.
    std::stable_sort(fitting.begin(), fitting.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<LensType> fallbacks;
    for (const auto& [e, r] : fitting) fallbacks.push_back(r);
    for (LensType r : options.references) fallbacks.push_back(r);
    fallbacks.push_back(LensType::Pinhole);
    for (LensType r : fallbacks)
      if (fitter.get(r).ok) return r;
  }
  return ref;
}

// One round's inlier flags from the fit's residuals; true when some flag changed.
bool update_inliers(const CalibrationProblem& pr, std::vector<BoardView>& views, const ViewSubset& sub,
                    const ModelFit& f, const OutlierOptions& options, OutlierReport& rep) {
  std::vector<std::vector<std::array<double, 2>>> rs;
  std::vector<double> comps;
  for (size_t i = 0; i < sub.size(); ++i) {
    rs.push_back(view_residuals(pr, f.model, f.warp, *sub[i], f.poses[i]));
    for (size_t k = 0; k < rs.back().size(); ++k)
      if (sub[i]->inlier[k] && std::isfinite(rs.back()[k][0])) {
        comps.push_back(std::abs(rs.back()[k][0]));
        comps.push_back(std::abs(rs.back()[k][1]));
      }
  }
  rep.sigma_px = 1.4826 * median_of(comps);
  rep.threshold_px = std::max(options.k * rep.sigma_px, options.floor_px);
  bool changed = false;
  for (size_t i = 0; i < sub.size(); ++i) {
    BoardView& v = views[size_t(sub[i] - views.data())];
    for (size_t k = 0; k < v.px.size(); ++k) {
      const char in = std::hypot(rs[i][k][0], rs[i][k][1]) <= rep.threshold_px;
      if (v.inlier[k] != in) {
        v.inlier[k] = in;
        changed = true;
      }
    }
  }
  return changed;
}

// Views with too many outliers lose their board; true when one did.
bool drop_views(const CalibrationProblem& pr, const std::vector<BoardView>& views, const OutlierOptions& options,
                OutlierReport& rep) {
  const int ncorners = pr.board.cols * pr.board.rows;
  bool changed = false;
  for (size_t i = 0; i < views.size(); ++i) {
    if (!rep.view_used[i]) continue;
    const int bad = int(std::count(views[i].inlier.begin(), views[i].inlier.end(), 0));
    if (bad > options.max_view_outlier_fraction * ncorners || ncorners - bad < 4) {
      rep.view_used[i] = 0;
      rep.why[i] = "too many outlier corners (" + std::to_string(bad) + " of " + std::to_string(ncorners) + ")";
      changed = true;
    }
  }
  return changed;
}

// A dropped view's corners under `f`: posed on every corner, then again on those within the
// threshold or 3x the median residual, until that set holds (a view's few bad corners, 8 of
// 196 5-8 px off, pulled a least-squares pose on all of them far enough that 143 missed
// 0.25 px). `keep` gets the last pose's robust set, `within` the corners within `threshold`;
// nullopt when the view cannot be posed.
std::optional<BoardPose> robust_pose(const CalibrationProblem& pr, const ModelFit& f, const BoardView& view,
                                     double threshold, std::vector<char>& keep, std::vector<char>& within) {
  BoardView v = view;
  std::fill(v.inlier.begin(), v.inlier.end(), 1);
  std::optional<BoardPose> pose;
  for (int pass = 0; pass < 4; ++pass) {
    const std::optional<BoardPose> p = solve_pose(pr, f.model, f.warp, v);
    if (!p) break;
    pose = p;
    const auto rs = view_residuals(pr, f.model, f.warp, v, *p);
    std::vector<double> r(rs.size());
    for (size_t k = 0; k < rs.size(); ++k) r[k] = std::hypot(rs[k][0], rs[k][1]);
    const double bound = std::max(threshold, 3 * median_of(r));
    keep.assign(r.size(), 0);
    within.assign(r.size(), 0);
    for (size_t k = 0; k < r.size(); ++k) {
      keep[k] = r[k] <= bound;
      within[k] = r[k] <= threshold;
    }
    if (keep == v.inlier || std::count(keep.begin(), keep.end(), 1) < 4) break;
    v.inlier = keep;
  }
  return pose;
}

// Views an earlier round dropped, taken back where this round's fit holds them within
// max_view_outlier_fraction at its threshold: posed under it (robust_pose), else with the
// fit refitted warm on the round's views and this one (a view beyond the others' field is not
// held by a fit that never saw it); true when one was. A dropped view was never looked at
// again: on 14 synthetic views of a wide rational lens (6000x3376, a 14x14 board) round 1's
// fit, pulled by a peripheral view's 8 bad corners, flagged 131 of its 196 and dropped it;
// the chosen model fitted the rest of that view as well as any other view.
bool restore_views(const CalibrationProblem& pr, std::vector<BoardView>& views, const ViewSubset& fitted,
                   const ModelFit& f, const OutlierOptions& options, OutlierReport& rep) {
  const int ncorners = pr.board.cols * pr.board.rows;
  const auto too_many = [&](const std::vector<char>& in) {
    const int bad = int(std::count(in.begin(), in.end(), 0));
    return bad > options.max_view_outlier_fraction * ncorners || ncorners - bad < 4;
  };
  bool changed = false;
  for (size_t i = 0; i < views.size(); ++i) {
    if (rep.view_used[i] || rep.why[i].rfind("too many outlier corners", 0) != 0) continue;
    std::vector<char> keep, within;
    const std::optional<BoardPose> pose = robust_pose(pr, f, views[i], rep.threshold_px, keep, within);
    if (!pose) continue;
    if (too_many(within)) {
      const std::vector<char> before = views[i].inlier;
      views[i].inlier = keep;
      ViewSubset with = fitted;
      with.push_back(&views[i]);
      std::vector<BoardPose> poses = f.poses;
      poses.push_back(*pose);
      const ModelFit g = warm_refit(pr, with, rep.reference, f, poses);
      views[i].inlier = before;
      if (!g.ok) continue;
      const auto rs = view_residuals(pr, g.model, g.warp, views[i], g.poses.back());
      for (size_t k = 0; k < rs.size(); ++k) within[k] = std::hypot(rs[k][0], rs[k][1]) <= rep.threshold_px;
      if (too_many(within)) continue;
    }
    views[i].inlier = within;
    rep.view_used[i] = 1;
    rep.why[i].clear();
    changed = true;
  }
  return changed;
}

// A round's cold fit this much worse than the last round's stopped short (reject_outliers).
constexpr double kStoppedShortFactor = 1.2;

// The last round's fit warm-started on `now` (a subset of the views it was fitted on).
ModelFit warm_from_last(const CalibrationProblem& pr, const OutlierReport& rep, const ViewSubset& now) {
  std::vector<BoardPose> poses;
  for (const BoardView* v : now)
    poses.push_back(rep.last_fit->poses[size_t(std::find(rep.last_views.begin(), rep.last_views.end(), v) -
                                               rep.last_views.begin())]);
  return warm_refit(pr, now, rep.reference, *rep.last_fit, poses);
}

}  // namespace

ViewSubset used_views(const std::vector<BoardView>& views, const std::vector<char>& used, int skip) {
  ViewSubset s;
  for (size_t i = 0; i < views.size(); ++i)
    if (used[i] && int(i) != skip) s.push_back(&views[i]);
  return s;
}

OutlierReport reject_outliers(const CalibrationProblem& problem, std::vector<BoardView>& views,
                              const OutlierOptions& options, const StageProgress& progress) {
  OutlierReport rep;
  rep.view_used.assign(views.size(), 1);
  rep.why.assign(views.size(), "");
  // How Mei is seeded in this calibration (SolveOptions::mei_from_kannala_brandt), decided
  // once from Kannala-Brandt on the reference sample, before any Mei fit: that fit is one of
  // the references the automatic choice fits anyway. A requested model (options.model) keeps
  // the unit-xi search: a forced Mei is nearly always a catadioptric lens, where the extra
  // Kannala-Brandt fit cost 16 % of the command (VMRImage) and would decide against it.
  // The other references do not depend on the decision: they are fitted on the sample beside
  // Kannala-Brandt and Mei (one job: Kannala-Brandt, the decision, Mei), so that the decision
  // waits for none of them (on fisheye1 the rational model's fit is 0.39 s, Kannala-Brandt's
  // 0.07-0.10 s, which the stage waited for first). choose_reference adopts every one.
  CalibrationProblem pr = problem;
  std::vector<std::pair<LensType, ModelFit>> on_sample;
  const auto& refs = options.references;
  const bool mei_may_be_fitted =
      !options.model && std::find(refs.begin(), refs.end(), LensType::OmnidirMei) != refs.end() &&
      std::find(refs.begin(), refs.end(), LensType::KannalaBrandt) != refs.end();
  if (mei_may_be_fitted) {
    const ViewSubset sample = evenly_spaced(used_views(views, rep.view_used), size_t(std::max(4, options.reference_views)));
    std::vector<LensType> others;
    for (LensType r : refs)
      if (r != LensType::KannalaBrandt && r != LensType::OmnidirMei) others.push_back(r);
    std::vector<std::optional<ModelFit>> fits(2 + others.size());  // KB, Mei, others
    // Kannala-Brandt, the decision, Mei, and the field they see; run once, by its own job or
    // by a perspective reference's job that needs the field first (std::call_once: a caller
    // waits only while another thread runs it).
    std::once_flag wide_once;
    WideField wide;
    // Mei seeded without Kannala-Brandt (the unit-xi search), as the chain solves it when
    // Kannala-Brandt does not decide for its own seed; shared, so that a perspective
    // reference's job whose seed misses the corners (a lens the chain will likely find too
    // wide for it) can solve it ahead of the chain, on the core that would wait (MiniOmni:
    // Kannala-Brandt's 0.18 s, then Mei's 0.12, had run one after the other). The same solve
    // whichever thread makes it.
    CalibrationProblem pr_omnidir = problem;
    pr_omnidir.solve.mei_from_kannala_brandt = false;
    CandidateSolver mei_omnidir(pr_omnidir, sample);
    const auto wide_chain = [&] {
      CandidateSolver kb(problem, sample);
      const ModelFit& f = kb.get(LensType::KannalaBrandt);
      pr.solve.mei_from_kannala_brandt = f.ok && fit_rms(problem, f, sample) <= kMeiFromKannalaBrandtRmsPx &&
                                         corner_field_deg(f.model, sample) <= kMeiFromKannalaBrandtFieldDeg;
      CandidateSolver mei_from_kb(pr, sample);
      CandidateSolver& mei = pr.solve.mei_from_kannala_brandt ? mei_from_kb : mei_omnidir;
      // Failed too: the field below asks this solver for Kannala-Brandt, which would solve it
      // again (KaidanOmni: cv::fisheye fails twice, 47 ms each).
      mei.adopt(LensType::KannalaBrandt, f);
      fits[0] = f;
      fits[1] = mei.get(LensType::OmnidirMei);
      wide = wide_fit_field(problem, mei, options.perspective_fit_rms_px);
    };
    // The perspective references' fits, one solver: the rational one's second start needs
    // plumb_bob's fit (rational_from_plumb_bob), which a last job solves beside the rational
    // refinement, on the core that finished the wide chain, where plumb_bob is no reference
    // itself. It waits for the field, as a perspective seed that misses the corners does: on
    // a mirror plumb_bob's misfit ran mrcal to 300 iterations. On 16 views of a 190 deg lens
    // the rational job had solved it after its own refinement, 0.12 s on one core while the
    // other waited.
    CandidateSolver solver(problem, sample);
    const bool rational_needs_plumb_bob =
        problem.solve.use_mrcal && std::find(others.begin(), others.end(), LensType::OpenCV8) != others.end() &&
        std::find(refs.begin(), refs.end(), LensType::OpenCV5) == refs.end();
    run_jobs(1 + others.size() + (rational_needs_plumb_bob ? 1 : 0), [&](size_t j) {
      if (j == 0) {
        std::call_once(wide_once, wide_chain);
        return;
      }
      if (j == 1 + others.size()) {
        std::call_once(wide_once, wide_chain);
        if (!(wide.deg > options.perspective_field_limit_deg)) solver.get(LensType::OpenCV5);
        return;
      }
      const LensType type = others[j - 1];
      // A sample large enough for CandidateSolver to seed on a part of it (reference_views
      // raised to 2 x SeedOptions::sample_views or more) is solved its way, ungated.
      if (sample.size() >= 2 * size_t(SeedOptions{}.sample_views)) {
        fits[1 + j] = solver.get(type);
        return;
      }
      const ModelFit seed =
          seed_candidate(problem, sample, type, [&](LensType t) -> const ModelFit& { return solver.get(t); }).fit;
      // A perspective seed that misses the corners waits for the field before its refinement,
      // which on a lens it cannot image runs mrcal to 300 iterations (OutlierOptions); a seed
      // that fits does not wait, so narrow lenses lose no time.
      if (seed.ok && is_perspective(type) && std::isfinite(options.perspective_field_limit_deg) &&
          !(fit_rms(problem, seed, sample) <= options.perspective_fit_rms_px)) {
        mei_omnidir.get(LensType::OmnidirMei);
        std::call_once(wide_once, wide_chain);
        if (wide.deg > options.perspective_field_limit_deg) return;  // left unfitted: choose_reference skips it
      }
      ModelFit fit = refine_seed(problem, sample, type, seed);
      if (type == LensType::OpenCV8) {
        fit = rational_from_plumb_bob(problem, sample, std::move(fit), solver.get(LensType::OpenCV5));
        // And from Kannala-Brandt's profile where the field is wide (rational_from_wide_profile),
        // as CandidateSolver does: the chain's fit of the sample, waited for here.
        if (!fit.ok || corner_field_deg(fit.model, sample) > kRationalFromWideProfileFieldDeg - 10) {
          std::call_once(wide_once, wide_chain);
          if (fits[0]) fit = rational_from_wide_profile(problem, sample, std::move(fit), *fits[0]);
        }
      }
      fits[1 + j] = solver.adopt(type, std::move(fit));
    }, options.parallel ? 0 : 1);
    const LensType order[2] = {LensType::KannalaBrandt, LensType::OmnidirMei};
    for (size_t i = 0; i < fits.size(); ++i)
      if (fits[i]) on_sample.emplace_back(i < 2 ? order[i] : others[i - 2], std::move(*fits[i]));
    rep.sample_fits = on_sample;
    if (rational_needs_plumb_bob)
      if (const ModelFit* pb = solver.solved(LensType::OpenCV5)) rep.sample_fits.emplace_back(LensType::OpenCV5, *pb);
    rep.sample_views = sample;
  }
  rep.mei_from_kannala_brandt = pr.solve.mei_from_kannala_brandt;
  std::optional<LensType> ref;
  double last_rms = std::numeric_limits<double>::infinity();  // the last round's fit's
  const int rounds = std::max(1, options.rounds);
  for (int round = 0; round < rounds; ++round) {
    report_progress(progress, "outlier rejection", size_t(round), size_t(rounds));
    CandidateSolver fitter(pr, used_views(views, rep.view_used));
    // Rounds after the first start from the last round's fit where that is the same minimum
    // (OutlierReport::reference_warm).
    if (rep.last_fit && rep.last_fit->ok && rep.reference_warm)
      fitter.adopt(*ref, warm_from_last(pr, rep, fitter.views()));
    if (!ref) ref = choose_reference(pr, fitter, options, on_sample);
    if (!ref || !fitter.get(*ref).ok) throw InputError("calibrate: no model could be fitted to the corners");
    rep.reference = *ref;
    // A cold round's fit much worse than the last round's stopped short: with outliers taken
    // out the best fit cannot be worse. It is refitted warm from the last round's, and that
    // kept where it fits better. An audit's 125 deg rational lens: round 3's rational fit
    // stuck at 2.48 px RMS after 0.43 px in round 2; its misfit flagged 93 more noise-only
    // corners and two views.
    if (round > 0 && !rep.reference_warm && rep.last_fit && rep.last_fit->ok) {
      const double cold = fit_rms(pr, fitter.get(*ref), fitter.views());
      if (!(cold <= kStoppedShortFactor * last_rms)) {
        ModelFit warm = warm_from_last(pr, rep, fitter.views());
        if (warm.ok && fit_rms(pr, warm, fitter.views()) < cold) {
          warm.solver += ", refitted warm from the last round";
          fitter.replace(*ref, std::move(warm));
        }
      }
    }
    const ModelFit& f = fitter.get(*ref);
    // Kannala-Brandt always; Mei where its xi is pinned: seeded from Kannala-Brandt (a narrow
    // lens), or corners seen beyond kMeiFromKannalaBrandtFieldDeg under its own fit (a mirror,
    // a wide lens). A Mei seeded otherwise on a narrow lens walks its xi/focal valley:
    // on Ladybug, when it was seeded so, warm rounds moved it by 0.17 px RMS and flagged
    // other corners. On the mirrors the warm rounds flag the same corners as the cold ones
    // did until stop 41, and a forced Mei calibration of KaidanOmni or MiniOmni takes 0.55-0.59
    // of the time (each cold round was a cv::omnidir seed and a Ceres solve, before stop 46's
    // unit-xi search).
    if (round == 0)
      rep.reference_warm = *ref == LensType::KannalaBrandt ||
                           (*ref == LensType::OmnidirMei &&
                            (pr.solve.mei_from_kannala_brandt ||
                             corner_field_deg(f.model, fitter.views()) > kMeiFromKannalaBrandtFieldDeg));
    rep.rounds = round + 1;
    bool changed = update_inliers(pr, views, fitter.views(), f, options, rep);
    changed = restore_views(pr, views, fitter.views(), f, options, rep) || changed;
    changed = drop_views(pr, views, options, rep) || changed;
    rep.last_fit = f;
    rep.last_views = fitter.views();
    last_rms = fit_rms(pr, f, fitter.views());
    rep.refit_needed = changed;
    if (!changed) break;
  }
  const ViewSubset used = used_views(views, rep.view_used);
  if (used.size() < 4)
    throw InputError("calibrate: only " + std::to_string(used.size()) +
                     " views left after outlier rejection, need at least 4");
  for (const BoardView* v : used) rep.corners_rejected += int(std::count(v->inlier.begin(), v->inlier.end(), 0));
  return rep;
}

std::optional<ModelFit> reference_fit(const CalibrationProblem& pr, const OutlierReport& rep, const ViewSubset& used) {
  if (!rep.last_fit || !rep.last_fit->ok) return std::nullopt;
  std::optional<ModelFit> f;
  if (!rep.refit_needed) {
    f = *rep.last_fit;
  } else if (rep.reference_warm) {
    // Warm, as the rounds were (see reject_outliers). On Ladybug the warm Mei is the cold
    // one's to 1e-6 px in every split and the command 0.94x.
    f = warm_from_last(pr, rep, used);
  }
  if (f) f->solver += ", carried from the outlier stage";  // what --json's table[].solver says
  return f;
}

std::vector<std::pair<LensType, ModelFit>> fits_from_sample(const CalibrationProblem& pr, const OutlierReport& rep,
                                                            const ViewSubset& used, double max_rms_px, bool parallel) {
  // The rational model's 12 parameters have several minima near each other: once corners
  // were flagged, the warm refit of its fit (outliers in) could stay in another one than the
  // cold solve finds (Ladybug: 0.2293 px RMS against 0.2282, and then chosen; fisheye1 0.560
  // against 0.552). It is carried only when no corner was flagged.
  const auto carries = [&](LensType t) { return t != LensType::OpenCV8 || rep.corners_rejected == 0; };
  const auto fits_within = [&](const std::pair<LensType, ModelFit>& tf) {
    return tf.second.ok && fit_rms(pr, tf.second, rep.sample_views) <= max_rms_px;
  };
  std::vector<const std::pair<LensType, ModelFit>*> carried;
  if (rep.sample_views == used)
    for (const auto& tf : rep.sample_fits)
      if (tf.first != rep.reference && carries(tf.first) && fits_within(tf)) carried.push_back(&tf);
  std::vector<std::optional<ModelFit>> refitted(carried.size());
  run_jobs(carried.size(), [&](size_t i) {
    const auto& [type, from] = *carried[i];
    ModelFit f = repose_stuck_views(pr, used, type, warm_refit(pr, used, type, from, from.poses));
    if (!f.ok) return;
    f.solver += ", refined warm from the outlier stage's sample";
    refitted[i] = std::move(f);
  }, parallel ? 0 : 1);
  std::vector<std::pair<LensType, ModelFit>> out;
  for (size_t i = 0; i < carried.size(); ++i)
    if (refitted[i]) out.emplace_back(carried[i]->first, std::move(*refitted[i]));
  // Where no corner was flagged, a fit that misses the corners by more than max_rms_px is the
  // cold solve of these very corners (with the outlier stage's board warp): carried as it is,
  // for the candidate stage to screen out, where another fit is within max_rms_px (so that the
  // screening applies). On 16 views of a 190 deg lens plumb_bob's (2.56 px RMS) had been
  // solved again, 0.11 s of CPU, only to be screened out.
  if (rep.sample_views == used && rep.corners_rejected == 0 &&
      std::any_of(rep.sample_fits.begin(), rep.sample_fits.end(), fits_within))
    for (const auto& tf : rep.sample_fits)
      if (tf.first != rep.reference && tf.second.ok && !fits_within(tf)) {
        ModelFit f = tf.second;
        f.solver += ", the outlier stage's fit of the same corners";
        out.emplace_back(tf.first, std::move(f));
      }
  return out;
}

}  // namespace lp
