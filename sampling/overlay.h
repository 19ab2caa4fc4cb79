// A picture for people: the map as a tone-mapped latlong image with the lights drawn on
// it, to see at a glance where a method put its lights and how bright they are.
//
// Image: width x width/2 latlong view (CONVENTIONS.md: pixel (u, v) centre at
// phi = 2 pi (u + 1/2) / W, theta = pi (v + 1/2) / H; row 0 straight up, phi growing
// to the right from +X towards +Y). A map in another layout or size is resampled to it
// with core/resample.h (power-preserving); invalid pixels (and the lower half of a
// hemisphere map) are drawn as a neutral grey checkerboard, never as black.
//
// Tone mapping: exposure k puts the `percentile` luminance of the valid pixels at
// `percentile_display` after Reinhard on luminance, c' = k c / (1 + k Y) per channel
// (hue kept, highlights compressed instead of clipped; for Reinhard y/(1+y) = 0.8 this
// is k = 4 / Y_p99). A saturated pixel whose largest channel still exceeds 1 is scaled
// down as a whole so that it keeps its hue.
//
// Lights: each a filled disc in the light's colour (rgb / max component, so a light is
// as bright as the display allows and its hue shows) with a dark one-pixel outline,
// centred on its (phi, theta); discs wrapping past the left or right edge appear on both.
// The radius grows with log10 of its luminance power relative to the brightest light:
// max radius for the brightest, shrinking linearly per decade to the min radius at
// `radius_decades` decades dimmer. Dimmer lights are drawn first, the brightest on top.
//
// Output of render_overlay: linear display RGB in [0, 1], 3 floats per pixel, row-major,
// not gamma-encoded; write_display_image applies the sRGB encoding when writing.
#pragma once

#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/light_list.h"
#include "core/tonemap.h"

namespace lp {

struct OverlayOptions {
  // Luminance percentile (0..1 over valid pixels) that sets the exposure, and the display
  // value it maps to. Lower the percentile for maps whose sun covers over 1% of pixels.
  double percentile = 0.99;
  double percentile_display = 0.8;
  // Disc radii in pixels; max_radius_px = 0 picks max(4, width / 128).
  double min_radius_px = 2;
  double max_radius_px = 0;
  // Luminance ratio, in decades below the brightest light, at which discs reach the min.
  double radius_decades = 3;
  // Checkerboard square size in pixels for invalid regions.
  int checker_px = 8;
  // > 0: this exposure instead of the percentile's (a live preview's temporal mapper,
  // core/temporal_tonemap.h).
  double exposure = 0;
  // How the invalid regions are drawn (core/tonemap.h): checkerboard or "no data" hatching.
  UnseenStyle unseen = UnseenStyle::Checker;
};

// Throws InputError when width is not a positive even number.
std::vector<float> render_overlay(const EnvMap& map, const std::vector<Light>& lights, int width,
                                  const OverlayOptions& options = {});

// render_overlay written through write_display_image (PNG or JPEG by extension).
// width = 0 picks the map's own width for a latlong map, 1024 otherwise.
void write_overlay_png(const std::string& path, const EnvMap& map, const std::vector<Light>& lights, int width = 0,
                       const OverlayOptions& options = {});

}  // namespace lp
