#include "calib/mrcal_optimization_inputs.h"

#include <stdexcept>
#include <utility>

#include "calib/lens_model.h"
#include "calib/numpy_archive.h"

namespace lp {

SolveRecord record_solve(const ViewSubset& views, const ModelFit& fit) {
  SolveRecord r;
  r.regularization = LensModel::parse(fit.model.lensmodel).is_splined();  // as calibration_solve.cpp solves them
  r.poses = fit.poses;
  r.warp_fitted = fit.warp_fitted;
  r.warp = fit.warp;
  for (const BoardView* v : views) {
    r.views.push_back(v->index);
    auto& obs = r.observations.emplace_back();
    for (size_t k = 0; k < v->px.size(); ++k) obs.push_back({v->px[k][0], v->px[k][1], v->inlier[k] ? 1.0 : -1.0});
  }
  return r;
}

std::string mrcal_optimization_inputs(const CameraModel& model, const BoardSpec& board, const SolveRecord& solve,
                                      const std::vector<std::string>& image_paths) {
  if (!is_mrcal_model(model.lensmodel))
    throw std::invalid_argument("optimization_inputs: " + model.lensmodel + " is not an mrcal lens model");
  const size_t nviews = solve.views.size(), ncorners = size_t(board.cols) * size_t(board.rows);
  if (nviews == 0 || solve.poses.size() != nviews || solve.observations.size() != nviews)
    throw std::invalid_argument("optimization_inputs: the solve record's views, poses and observations differ");
  std::vector<double> frames, observations;
  std::vector<int32_t> indices;
  std::vector<std::string> paths;
  for (size_t i = 0; i < nviews; ++i) {
    frames.insert(frames.end(), solve.poses[i].begin(), solve.poses[i].end());
    if (solve.observations[i].size() != ncorners)
      throw std::invalid_argument("optimization_inputs: a view without cols x rows corners");
    for (const auto& o : solve.observations[i]) observations.insert(observations.end(), o.begin(), o.end());
    indices.insert(indices.end(), {int32_t(i), 0, -1});  // frame i, camera 0, at the reference
    const size_t image = size_t(solve.views[i]);
    paths.push_back(image < image_paths.size() ? image_paths[image] : "");
  }
  // Keys and kinds in the order mrcal-calibrate-cameras passes them to mrcal.optimize().
  // do_optimize_extrinsics is true as there (there are none): mrcal's uncertainty refuses
  // a solve with it false.
  using V = NpyValue;
  const std::vector<std::pair<std::string, NpyValue>> dict = {
      {"intrinsics", V::array(model.intrinsics, {1, model.intrinsics.size()})},
      {"extrinsics_rt_fromref", V::array(std::vector<double>{}, {0, 6})},
      {"frames_rt_toref", V::array(std::move(frames), {nviews, 6})},
      {"points", V::none()},
      {"observations_board",
       V::array(std::move(observations), {nviews, size_t(board.rows), size_t(board.cols), 3})},
      {"indices_frame_camintrinsics_camextrinsics", V::array(std::move(indices), {nviews, 3})},
      {"observations_point", V::none()},
      {"indices_point_camintrinsics_camextrinsics", V::none()},
      {"lensmodel", V::text(model.lensmodel)},
      {"imagersizes", V::array(std::vector<int32_t>{model.width, model.height}, {1, 2})},
      {"calobject_warp", solve.warp_fitted ? V::array(std::vector<double>{solve.warp[0], solve.warp[1]}, {2})
                                           : V::none()},
      {"do_optimize_intrinsics_core", V::scalar(true)},
      {"do_optimize_intrinsics_distortions", V::scalar(true)},
      {"do_optimize_extrinsics", V::scalar(true)},
      {"do_optimize_frames", V::scalar(true)},
      {"do_optimize_calobject_warp", V::scalar(solve.warp_fitted)},
      {"calibration_object_spacing", V::scalar(board.square_mm)},
      {"do_apply_outlier_rejection", V::scalar(false)},
      {"do_apply_regularization", V::scalar(solve.regularization)},
      {"verbose", V::scalar(false)},
      {"imagepaths", V::texts(std::move(paths))},
  };
  return base85_encode(npz_bytes(dict));
}

}  // namespace lp
