// eval ball: how precisely find_ball (probe/mirror_ball.h) finds a mirror ball's centre
// and radius, on orthographic balls rendered from known maps at several sizes, off-centre
// sub-pixel positions and over five backgrounds (docs/probes.md "Finding the ball"):
//   black  nothing behind the ball;
//   photo  a photograph behind the ball, scaled to the ball's mean luminance;
//   sun    the photo, and a sun (1.5 deg, 1e4 x the map's mean) 8 deg from the blind
//          spot, so that its reflection is a blinding arc at the rim;
//   dark   the photo darkened 100 x, and the map black over the lower hemisphere beyond
//          150 deg from the view direction (a dark object behind the ball): along half
//          the rim, its outer 3.4 % of the radius, dark meets dark;
//   night  the map and the photo scaled down 1000 x, with sensor noise (additive sigma
//          0.05 x the image's mean, 2 % multiplicative).
// Rim pixels blend ball and background by their exact 4 x 4 sub-sample coverage, as the
// renderer does on a constant background.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/envmap.h"
#include "core/image_io.h"
#include "eval/harness.h"
#include "probe/mirror_ball.h"

namespace lp {

enum class BallBackground { Black, Photo, Sun, Dark, Night };
const char* background_name(BallBackground b);
std::vector<BallBackground> all_ball_backgrounds();

// One synthetic photo of a ball and the truth it was rendered with.
struct BallCase {
  RgbImage image;
  BallInImage truth;
};

// A ball of radius `radius_px` reflecting `world` in front of `background`; the image is
// about 2.9 x 2.5 radii times `frame` (1: a crop around the ball; 2.3: the ball a sixth of
// the frame's width, as an uncropped photo frames it), the centre placed off-centre with
// sub-pixel offsets drawn from `seed`. `photo` (any size, resampled to the image) is needed for every background but
// Black. Throws InputError on a radius below 8 px or a missing photo.
BallCase render_ball_case(const EnvMap& world, BallBackground background, double radius_px, const RgbImage& photo,
                          uint64_t seed, double frame = 1);

struct EvalBallOptions {
  // Map files (latlong), or directories of six cube faces (probe/cube_map.h).
  std::vector<std::string> maps;
  std::string photo;  // the image put behind the ball
  std::vector<double> radii{60, 150, 400};
  std::vector<BallBackground> backgrounds = all_ball_backgrounds();
  std::string output_dir;  // created; receives ball.csv (empty: no file)
  // With output_dir: a picture of every case found beyond `picture_beyond_px` (centre or
  // radius error), ball_<map>_<background>_R<r>.png, the render tone-mapped around the ball
  // with the true rim in green and the found one in red (a case missed: the true rim
  // alone). Negative: no pictures.
  double picture_beyond_px = -1;
  // A subset of the grid (empty: all): cases for which it returns false are skipped, and
  // the others keep the seeds, hence the renders, they have in the whole grid.
  std::function<bool(const std::string& map_label, double radius_px, BallBackground)> include;
  double frame = 1;  // render_ball_case's frame: the image's size in units of the crop's
};

struct BallRow {
  std::string map, background;
  double radius_px = 0;
  bool found = false;          // false: find_ball threw (error holds its message)
  std::string error;
  double centre_error_px = 0;  // |found centre - truth|
  double radius_error_px = 0;  // found radius - truth (signed)
  FindBallReport report;       // the detector's own confidence and uncertainty
  double ms = 0;               // find_ball alone
  double unwrap_ms = 0;        // unwrapping the photo to latlong 1024 x 512, for scale
};

struct EvalBallReport {
  std::vector<BallRow> rows;  // map x radius x background, in that order
  std::string csv_path;
  std::string summary() const;       // the table, and per background the worst errors
  nlohmann::json to_json() const;    // {"csv", "rows": [...]}
};

// A map with nothing to reflect (all black, e.g. a single-pixel spot) on a black
// background leaves nothing to find: such cases are listed as not found ("nothing to
// see"). InputError when a map or the photo cannot be read.
EvalBallReport evaluate_ball_detection(const EvalBallOptions& options, const EvalProgress& progress = {});

}  // namespace lp
