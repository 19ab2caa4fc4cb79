// An exposure bracket: several 8- or 16-bit photographs of one static scene, each with
// its exposure time in seconds, as the input of response recovery (hdr/response.h) and
// merging (hdr/merge.h).
//
// Frames hold code values in [0, 1] exactly as core's read_camera_image gives them (no
// response applied); frame k was exposed for exposure_seconds[k]. Frames need not be
// sorted by exposure.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/image_io.h"

namespace lp {

struct Bracket {
  std::vector<RgbImage> frames;          // code values in [0, 1], all the same size
  std::vector<double> exposure_seconds;  // one per frame, positive and finite
  int bit_depth = 8;                     // 8 or 16 (of the files read)
  std::vector<std::string> paths;        // one per frame, or empty for brackets made in memory
  bool linear = false;                   // camera RAW frames: linear sensor values, no response curve
  // Optional (keep_8bit_codes): per frame, the level merge_bracket takes of each code value of
  // frames[k] at 256 levels, packed RGB (3 * width * height bytes). A merge through a 256-level
  // response then reads these instead of the floats (a quarter of the bytes) and gives the same
  // image bit for bit. Empty: the floats. Whoever changes frames (align_frames) must clear it.
  std::vector<std::vector<uint8_t>> codes;
  // The frames' colours, when the first file's ICC profile is a matrix one other than sRGB
  // (Adobe RGB, Display P3, ProPhoto from a raw converter): row-major, linear values in it to
  // Rec. 709, for whoever makes radiance of them (hdr fuse). Empty: sRGB, no profile, or a
  // profile that cannot be applied (a LUT one, warned about).
  std::optional<std::array<double, 9>> to_rec709;
  std::string colour_profile;  // that profile's description
  // 16-bit files that hold a 10- to 15-bit sensor's codes in their low bits: the code the
  // clipping piles up at, which read_bracket has mapped to 1.0 (0: the container's top).
  int white_level = 0;
  // The first frame's ISO and f-number where every frame records them (0: not every frame
  // does): exposure_seconds are relative to them. reference_exposure_scale reads them.
  double iso = 0, f_number = 0;
  // The EXIF Orientation the frames were turned by (1: as stored; frames whose tags disagree
  // are read as stored).
  int orientation = 1;
  // Where `probe register` put the ball, when every frame records the same place (PNG tEXt,
  // core/image_io.h), in the frames as turned: hdr fuse records it in the fused image.
  std::optional<std::array<double, 3>> mirror_ball;

  int width() const { return frames.empty() ? 0 : frames[0].width; }
  int height() const { return frames.empty() ? 0 : frames[0].height; }
};

// Throws InputError naming the first offending file (or "bracket" when it has no paths):
// fewer than 2 frames, a size that differs from the one most frames have (so the odd frame
// is named, even when it is the first), a time count that does not match the frame count,
// a time that is not positive and finite, two frames with the same time (both named).
void check_bracket(const Bracket& bracket);

// Fills bracket.codes from its frames: per code value v, int(min(v * 255 + 0.5, 255)), 0 for
// v <= 0 and NaN (merge_bracket's level at 256 levels, so k / 255 gives back k for every 8-bit
// code k; tests/hdr/merge_codes_test.cpp).
void keep_8bit_codes(Bracket& bracket);

// 16-bit frames (not RAW) whose codes never reach the container's top half and pile up at
// their largest code (at least 16 values, and 1 in 10,000): a sensor of fewer bits whose
// codes were stored as they came, clipped at that code. Maps that code to 1.0 (c / white
// level), sets white_level and warns in one line; otherwise leaves the bracket as it is.
void apply_sensor_white_level(Bracket& bracket);

// Reads every image (read_camera_image) and its exposure time: from `exposure_seconds`
// when given (one per path, same order), else from each file's EXIF ExposureTime, else
// InputError("<file>: no exposure time in EXIF; give --exposure-times"). Where every frame's
// EXIF records its ISO (or f-number) and they differ, each frame's exposure_seconds is its
// time x ISO / f-number^2 relative to the first frame's, said in one warning (auto-ISO and
// ISO or aperture bracketing). A frame at the exposure of an earlier one is left out, said in
// one warning (refused when their codes differ beyond one exposure: a wrong time). All files
// must have the same bit depth. The result passes check_bracket, has its sensor's white level
// applied (apply_sensor_white_level); a bracket of 8-bit files keeps their codes too
// (keep_8bit_codes).
Bracket read_bracket(const std::vector<std::string>& paths,
                     const std::optional<std::vector<double>>& exposure_seconds = std::nullopt);

// The exposure time recorded in a file's EXIF (Exif.Photo.ExposureTime, else
// Exif.Image.ExposureTime, else the APEX Exif.Photo.ShutterSpeedValue), in seconds;
// nullopt when the file carries none. Throws InputError when the file cannot be read.
std::optional<double> read_exif_exposure_seconds(const std::string& path);

// What a file's EXIF says of its exposure: the time as read_exif_exposure_seconds reads it,
// and the ISO and f-number (Exiv2's isoSpeed and fNumber; 0 where not recorded).
struct ExifExposureSettings {
  std::optional<double> seconds;
  double iso = 0, f_number = 0;
};
ExifExposureSettings read_exif_exposure(const std::string& path);

// A camera file's colours when its ICC profile is a matrix one other than sRGB (Adobe RGB,
// Display P3, ProPhoto from a raw converter): the profile's description and the matrix from
// linear values in it to Rec. 709 (row-major). nullopt for sRGB, no profile, or a profile
// that cannot be applied (a LUT one: said in one warning, once per profile and process).
struct ColourProfile {
  std::string name;
  std::array<double, 9> to_rec709;
};
std::optional<ColourProfile> read_colour_profile(const std::string& path);

// Where every frame records an ISO (or f-number) in `settings` (one per frame) and they
// differ, multiplies each frame's exposure_seconds by its ISO / f-number^2 relative to the
// first frame's and warns in one line; otherwise leaves the bracket as it is.
void fold_iso_and_aperture(Bracket& bracket, const std::vector<ExifExposureSettings>& settings);

// A fused map's values are code / t at the first frame's ISO and f-number: the same scene at
// ISO 400, or at f/4 instead of f/2, gives a map 4 times brighter, and a photometric
// calibration (one k per camera) fitted at one setting is wrong at any other. Scaling by
// (100 / ISO) x N^2 puts every map at ISO 100 and f/1, where k is the camera's alone (the
// reflected-light meter's equation, L = K N^2 / (t S)). Returns that factor from what
// the bracket records (1 for a setting it does not; both unrecorded: 1).
double reference_exposure_scale(const Bracket& bracket);

// A list of exposure times in seconds, in file order. Accepts:
//  - one time per line ("0.025" or "1/40"), blank lines and '#' comments skipped;
//  - CSV "file,seconds[,...]" with an optional header line (the exposures.csv files
//    of the shared data sets: "filename,exposure_time_s,exposure_time_fraction");
//  - whitespace-separated "file seconds ..." (Debevec's hdr_image_list.txt).
// Rule per line: the first field when it is a number, else the second. A first line whose
// time field is not a number is a header. Throws InputError naming the file and line.
std::vector<double> read_exposure_list(const std::string& csv_or_txt);

// One line of an exposure list: its time, the file it names (empty when the line holds a
// time alone) and its line number.
struct ExposureEntry {
  std::string file;
  double seconds = 0;
  int line = 0;
};
// The lines of an exposure list as read_exposure_list reads them, with their names.
std::vector<ExposureEntry> read_exposure_entries(const std::string& csv_or_txt);

// The times of `images`, in their order. A list that names its files is looked up by name
// (an image's path as given, else its file name, else its stem: ball.png finds ball.jpg's
// line), so the images may be any of them in any order; a list of times alone is taken in
// order and must have one per image. Throws InputError naming the list and the image for an
// image it does not name, a name given twice, or a list that mixes named and unnamed lines.
std::vector<double> exposure_times_for(const std::string& csv_or_txt, const std::vector<std::string>& images);

}  // namespace lp
