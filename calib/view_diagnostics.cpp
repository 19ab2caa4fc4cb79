#include "calib/view_diagnostics.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "calib/calibration_solve.h"
#include "calib/outlier_rejection.h"
#include "calib/parallel_jobs.h"
#include "calib/projection_difference.h"

namespace lp {

ViewDiagnostics diagnose_views(const CalibrationProblem& pr, const std::vector<BoardView>& views,
                               const std::vector<char>& view_used, const ModelFit& chosen,
                               std::vector<ViewReport>& view_reports, const CoverageOptions& o) {
  ViewDiagnostics d;
  const int width = pr.width, height = pr.height;
  d.view_rms_px.assign(view_reports.size(), 0.0);
  d.coverage_nx = std::max(1, o.nx);
  d.coverage_ny = std::max(1, o.ny);
  d.coverage.assign(size_t(d.coverage_nx) * d.coverage_ny, 0);
  size_t ui = 0;
  for (size_t i = 0; i < views.size(); ++i) {
    const BoardView& v = views[i];
    BoardPose pose;
    if (view_used[i]) {
      pose = chosen.poses[ui++];
    } else {
      const auto p = solve_pose(pr, chosen.model, chosen.warp, v);
      if (!p) continue;
      pose = *p;
    }
    const auto r = view_residuals(pr, chosen.model, chosen.warp, v, pose);
    std::vector<double> sq;
    int rejected = 0;
    for (size_t k = 0; k < r.size(); ++k) {
      d.residuals.push_back({v.index, int(k), r[k][0], r[k][1], !v.inlier[k]});
      d.corners_total++;
      if (!v.inlier[k]) {
        rejected++;
        continue;
      }
      sq.push_back(r[k][0] * r[k][0] + r[k][1] * r[k][1]);
      if (!view_used[i]) continue;
      const double x = v.px[k][0], y = v.px[k][1];
      const int cx = std::clamp(int((x + 0.5) / width * d.coverage_nx), 0, d.coverage_nx - 1);
      const int cy = std::clamp(int((y + 0.5) / height * d.coverage_ny), 0, d.coverage_ny - 1);
      d.coverage[size_t(cy) * d.coverage_nx + cx]++;
      const double bx = o.edge_band * width, by = o.edge_band * height;
      if (x < bx) d.edge_observations[0]++;
      if (x > width - bx) d.edge_observations[1]++;
      if (y < by) d.edge_observations[2]++;
      if (y > height - by) d.edge_observations[3]++;
    }
    d.corners_rejected += rejected;
    ViewReport& vr = view_reports[size_t(v.index)];
    vr.rejected_corners = rejected;
    vr.used = view_used[i];
    vr.rms_px = rms_of(sq);
    d.view_rms_px[size_t(v.index)] = vr.rms_px;
  }
  for (int e : d.edge_observations)
    if (e < o.min_edge_observations) d.corners_poorly_covered = true;
  return d;
}

std::vector<CameraModel> view_leverage(const CalibrationProblem& pr, const std::vector<BoardView>& views,
                                       const std::vector<char>& view_used, LensType type, const ModelFit& chosen,
                                       const std::vector<uint8_t>& mask, int step,
                                       std::vector<ViewReport>& view_reports, const LeverageOptions& o,
                                       const StageProgress& progress) {
  // One warm refit per used view, on every core (o.parallel); each writes its own slot.
  std::vector<size_t> used;
  for (size_t i = 0; i < views.size(); ++i)
    if (view_used[i]) used.push_back(i);
  std::vector<ModelFit> refits(used.size());
  std::vector<double> moved(used.size(), std::numeric_limits<double>::infinity());
  report_progress(progress, "leverage", 0, 1);
  // The refit and its projection difference in the same job: the differences (rotation fitted
  // out over the covered area) took as long as the refits and ran on one core after them. The
  // chosen fit's rays are unprojected once for all of them.
  const GridRays chosen_rays = grid_rays(chosen.model, mask, step);
  run_jobs(used.size(), [&](size_t u) {
    const size_t i = used[u];
    std::vector<BoardPose> poses;
    for (size_t j = 0; j < used.size(); ++j)
      if (j != u) poses.push_back(chosen.poses[j]);
    refits[u] = warm_refit(pr, used_views(views, view_used, int(i)), type, chosen, poses);
    if (refits[u].ok) {
      const ProjectionDiff d = projection_difference(refits[u].model, chosen.model, chosen_rays);
      if (d.samples > 0) moved[u] = d.rms_px;
    }
  }, o.parallel ? 0 : 1);
  std::vector<CameraModel> leave_one_out;
  std::vector<double> lev;
  std::vector<int> idx;
  for (size_t u = 0; u < used.size(); ++u) {
    const ModelFit& f = refits[u];
    const double l = moved[u];
    if (f.ok) leave_one_out.push_back(f.model);
    view_reports[size_t(views[used[u]].index)].leverage_px = l;
    lev.push_back(l);
    idx.push_back(views[used[u]].index);
  }
  const double med = median_of(lev);
  for (size_t j = 0; j < lev.size(); ++j)
    view_reports[size_t(idx[j])].influential = lev[j] > o.flag_factor * med && lev[j] > o.min_px;
  return leave_one_out;
}

}  // namespace lp
