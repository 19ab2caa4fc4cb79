// Lens vignetting (relative illumination): the share of the image centre's irradiance that a
// pixel receives from a uniform scene. Fisheye and wide lenses lose up to one or two stops
// towards the rim, so an uncorrected probe takes the horizon's lights for dimmer than they
// are, and its photometric scale depends on where the meter's patches sat.
//
// Model (lensfun's "pa" vignetting model and its normalisation, with the two further even terms
// of Adobe DNG's FixVignetteRadial: three cannot follow a steep falloff, 3 % off at the
// corners of a cos^4 lens whose corners get a third of the centre's light):
//   V(r) = 1 + k1 r^2 + k2 r^4 + k3 r^6 + k4 r^8 + k5 r^10,   r = |p - centre| / (half the image diagonal)
// p and centre in pixel coordinates with pixel centres at integers (as a camera matrix's cx,
// cy). Beyond the largest r the flats measured (max_radius: outside a fisheye's image circle,
// corners the flats left dark) V goes on along its tangent at max_radius, but never below
// half of V(max_radius): an even polynomial extrapolated there can turn in any direction.
//
// Measured from flat fields: images of a uniformly lit, featureless surface filling the view
// (an opal diffuser or a sheet of white plastic over the lens under even light, an integrating
// sphere, a clear sky through a diffuser). Light that is not uniform across a flat is taken
// for vignetting: turning the camera about its axis between flats averages a gradient out, and
// the per-flat residuals show one.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/image_io.h"

namespace lp {

struct VignettingModel {
  int image_width = 0, image_height = 0;
  std::array<double, 2> centre{0, 0};  // px, pixel centres at integers
  double radius_px = 1;                // r = 1 at this distance: half the image diagonal
  static constexpr int kMaxTerms = 5;
  std::array<double, kMaxTerms> k{};   // k1..k5; unused terms are 0
  int terms = 0;                       // how many of k were fitted (1-5)
  double max_radius = 1;               // the largest r measured; V is extrapolated beyond it
  // Fit quality, as measured on the flats' blocks (relative: 0.01 = 1 %).
  double rms_relative = 0;
  double edge_sigma_relative = 0;      // 1-sigma uncertainty of V at max_radius, relative
  int flats = 0;
  size_t blocks = 0, blocks_dropped = 0;  // blocks fitted, and left out as outliers (dust, specks)
  std::string centre_from = "fit";     // "fit", or "image" when the fit could not place it
  // The flats' f-number (EXIF), 0 when unrecorded. Optical vignetting changes with the
  // aperture (a lens wide open loses a stop more at the rim than stopped down), so a model is
  // for the aperture it was measured at.
  double f_number = 0;
};

// V at pixel (x, y) (pixel centres at integers), extrapolated beyond max_radius as above.
double relative_illumination(const VignettingModel& model, double x, double y);

// One flat field: linear luminance (any scale), width x height, row-major; NaN marks a pixel
// that cannot be used (clipped in a channel, no data).
struct FlatField {
  int width = 0, height = 0;
  std::vector<float> luminance;
  std::string name;  // the file, for messages
};

struct VignettingFitOptions {
  // Terms of the polynomial: 0 = the fewest of 1-5 that the flats support (Bayesian
  // information criterion over the blocks), else exactly this many.
  int terms = 0;
  // Blocks (means over about 1/64 of the short side, square) darker than this share of a
  // flat's bright level (99th percentile of its blocks) are outside the lens's image or too
  // dark to measure, and left out; so is a block with a pixel below a third of its mean (the
  // edge of a fisheye's image circle, a speck).
  double dark_fraction = 0.05;
  // After a first fit, blocks whose residual differs from their neighbourhood's (the 5 x 5
  // blocks around) by more than this many robust standard deviations (and more than 1 %) are
  // left out and the fit is repeated: dust on the lens or the diffuser. Where the model misfits
  // a lens the residual changes slowly, and those blocks stay.
  double outlier_sigmas = 5;
};

// Fits the model to one or more flats of one size (InputError naming the file otherwise, or
// when too few blocks are measurable, or when the fit is not a falloff: V at or below 0.02,
// or rising above 1.5, within the measured radius). Each flat has its own scale. The centre
// is fitted; where the falloff is too weak to place it (it would move by more than a tenth of
// the half-diagonal) it is held at the image centre (centre_from "image").
VignettingModel fit_vignetting(const std::vector<FlatField>& flats, const VignettingFitOptions& options = {});

// The block samples of the last fit's kind, for a picture: r and the flat's value over its
// fitted scale. Computed as fit_vignetting does, at most `max_points` (evenly thinned).
struct VignettingSample {
  double r = 0, value = 0;
};
std::vector<VignettingSample> vignetting_samples(const std::vector<FlatField>& flats, const VignettingModel& model,
                                                 size_t max_points = 4000);

// Divides every pixel of `image` (radiance, not codes: InputError) by V. `file` names the
// calibration in the InputError when the image's size is not the model's.
void correct_vignetting(RgbImage& image, const VignettingModel& model, const std::string& file);
// 1 / V at source positions given in the remap convention (pixel centres at +0.5,
// probe/remap.h); 1 where a coordinate is NaN. For a map unwrapped from a camera image:
// multiplying each map pixel by its gain corrects the vignetting of where it was read.
std::vector<float> inverse_vignetting_at(const VignettingModel& model, const std::vector<float>& src_x,
                                         const std::vector<float>& src_y);
// Models are in the sensor's frame: flats are read as stored, whatever their EXIF Orientation
// (a property of the lens on the sensor, not of how a viewer turns a photo). For images read
// as their EXIF Orientation shows them (1-8, core/image_io.h), the model turned the same way.
VignettingModel vignetting_as_shown(const VignettingModel& stored, int orientation);
// InputError naming `file` when the model was measured on another image size.
void check_vignetting_size(const VignettingModel& model, int width, int height, const std::string& file);
// A one-line warning when the model and the images it is applied to record f-numbers more
// than a sixth of a stop apart; empty when they agree or either is unrecorded (0).
std::string aperture_mismatch(const VignettingModel& model, double f_number, const std::string& model_file,
                              const std::string& images);

// JSON "lightprobe.vignetting/1" (written atomically); load refuses another format, missing
// fields, a size or radius that is not positive, or coefficients that are not finite.
void save_vignetting(const std::string& path, const VignettingModel& model);
VignettingModel load_vignetting(const std::string& path);

}  // namespace lp
