// Colour match of a probe camera to a backplate camera: a 3x3 linear transform M with
// plate_rgb ~ M * probe_rgb, fitted by least squares from corresponding patches (a colour
// chart seen by both cameras), so that virtual objects lit by the probe match the footage.
// Linear RGB in, linear RGB out; at least 3 patches with independent colours.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/vec3.h"

namespace lp {

struct ColourPatchPair {
  std::array<double, 3> probe{0, 0, 0};  // the patch as the probe camera sees it (linear)
  std::array<double, 3> plate{0, 0, 0};  // the same patch in the backplate camera (linear)
};

struct ColourMatch {
  Mat3 matrix{};        // plate = matrix * probe
  double rms_relative = 0;  // RMS of |M p - q| / |q| over the patches
  int patches = 0;
};

// Throws InputError for fewer than 3 patches, non-finite or negative values, or patches
// whose probe colours do not span RGB (the fit would be singular).
ColourMatch fit_colour_match(const std::vector<ColourPatchPair>& pairs);

// CSV with header probe_r,probe_g,probe_b,plate_r,plate_g,plate_b; errors name file:line.
std::vector<ColourPatchPair> read_colour_patches_csv(const std::string& path);
void save_colour_match(const std::string& path, const ColourMatch& match);
ColourMatch load_colour_match(const std::string& path);

// Applies the matrix to every pixel (negative results clamped to 0: light cannot be negative).
void apply_colour_match(EnvMap& map, const ColourMatch& match);

}  // namespace lp
