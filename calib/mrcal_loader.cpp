// mrcal, loaded on first use. libmrcal links FreeImage, and through it JPEG XR, OpenJPEG,
// TIFF, WebP and LibRaw: 15 shared libraries that every lightprobe command loaded at start,
// though only calibration and mrcal camera models call mrcal. The library is not linked;
// these definitions of the mrcal functions the project calls forward to the real ones,
// which the first call loads from libmrcal.so.2 (Debian's libmrcal2) with dlopen.
//
// The definitions are checked against mrcal.h by the compiler (a C function cannot be
// overloaded: a wrong parameter list does not compile). A program that also links libmrcal
// (a test) still works: dlsym on mrcal's own handle finds mrcal's definitions, not these.
// A function the project starts to call must be added here: the link fails until it is.
#include "core/lazy_function.h"

extern "C" {
#include <mrcal/mrcal.h>
}

namespace {

constexpr const char* kMrcalLibrary = "libmrcal.so.2";

#define LP_MRCAL(name) LP_LAZY_FUNCTION(kMrcalLibrary, "mrcal 2.x", name)

}  // namespace

extern "C" {

bool mrcal_lensmodel_from_name(mrcal_lensmodel_t* lensmodel, const char* name) {
  LP_MRCAL(mrcal_lensmodel_from_name);
  return real(lensmodel, name);
}

bool mrcal_lensmodel_name(char* out, int size, const mrcal_lensmodel_t* lensmodel) {
  LP_MRCAL(mrcal_lensmodel_name);
  return real(out, size, lensmodel);
}

mrcal_lensmodel_metadata_t mrcal_lensmodel_metadata(const mrcal_lensmodel_t* lensmodel) {
  LP_MRCAL(mrcal_lensmodel_metadata);
  return real(lensmodel);
}

int mrcal_lensmodel_num_params(const mrcal_lensmodel_t* lensmodel) {
  LP_MRCAL(mrcal_lensmodel_num_params);
  return real(lensmodel);
}

bool mrcal_project(mrcal_point2_t* q, mrcal_point3_t* dq_dp, double* dq_dintrinsics, const mrcal_point3_t* p, int N,
                   const mrcal_lensmodel_t* lensmodel, const double* intrinsics) {
  LP_MRCAL(mrcal_project);
  return real(q, dq_dp, dq_dintrinsics, p, N, lensmodel, intrinsics);
}

bool mrcal_unproject(mrcal_point3_t* v, const mrcal_point2_t* q, int N, const mrcal_lensmodel_t* lensmodel,
                     const double* intrinsics) {
  LP_MRCAL(mrcal_unproject);
  return real(v, q, N, lensmodel, intrinsics);
}

mrcal_cameramodel_t* mrcal_read_cameramodel_string(const char* string, int len) {
  LP_MRCAL(mrcal_read_cameramodel_string);
  return real(string, len);
}

void mrcal_free_cameramodel(mrcal_cameramodel_t** cameramodel) {
  LP_MRCAL(mrcal_free_cameramodel);
  real(cameramodel);
}

mrcal_stats_t mrcal_optimize(double* b_packed, int buffer_size_p_packed, double* x, int buffer_size_x,
                             double* intrinsics, mrcal_pose_t* extrinsics_fromref, mrcal_pose_t* frames_toref,
                             mrcal_point3_t* points, mrcal_calobject_warp_t* calobject_warp, int Ncameras_intrinsics,
                             int Ncameras_extrinsics, int Nframes, int Npoints, int Npoints_fixed,
                             const mrcal_observation_board_t* observations_board,
                             const mrcal_observation_point_t* observations_point, int Nobservations_board,
                             int Nobservations_point, mrcal_point3_t* observations_board_pool,
                             const mrcal_lensmodel_t* lensmodel, const int* imagersizes,
                             mrcal_problem_selections_t problem_selections,
                             const mrcal_problem_constants_t* problem_constants, double calibration_object_spacing,
                             int calibration_object_width_n, int calibration_object_height_n, bool verbose,
                             bool check_gradient) {
  LP_MRCAL(mrcal_optimize);
  return real(b_packed, buffer_size_p_packed, x, buffer_size_x, intrinsics, extrinsics_fromref, frames_toref, points,
              calobject_warp, Ncameras_intrinsics, Ncameras_extrinsics, Nframes, Npoints, Npoints_fixed,
              observations_board, observations_point, Nobservations_board, Nobservations_point,
              observations_board_pool, lensmodel, imagersizes, problem_selections, problem_constants,
              calibration_object_spacing, calibration_object_width_n, calibration_object_height_n, verbose,
              check_gradient);
}

}  // extern "C"
