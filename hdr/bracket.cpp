#include "hdr/bracket.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <numeric>
#include <set>
#include <sstream>

#include <fmt/format.h>

#include "core/chromaticities.h"
#include "core/error.h"
#include "core/sensor_white_level.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/picture_io.h"
#include "core/warnings.h"
#include "hdr/camera_files_plugin.h"
#include "hdr/raw_input.h"

namespace lp {
namespace {

namespace fs = std::filesystem;

std::string frame_name(const Bracket& b, size_t k) {
  return k < b.paths.size() ? b.paths[k] : fmt::format("bracket frame {}", k);
}

// "0.025", "2.5e-2" or "1/40"; nullopt when the text is not one whole number.
std::optional<double> parse_seconds(const std::string& text) {
  auto parse_number = [](const std::string& s) -> std::optional<double> {
    if (s.empty()) return std::nullopt;
    size_t used = 0;
    try {
      const double v = std::stod(s, &used);
      if (used != s.size()) return std::nullopt;
      return v;
    } catch (const std::exception&) {
      return std::nullopt;
    }
  };
  const size_t slash = text.find('/');
  if (slash == std::string::npos) return parse_number(text);
  const auto num = parse_number(text.substr(0, slash));
  const auto den = parse_number(text.substr(slash + 1));
  if (!num || !den || *den == 0.0) return std::nullopt;
  return *num / *den;
}


// Frames at one exposure (time x ISO / f-number^2): a camera at its shortest or longest time
// repeats it when an auto-bracket asks for more (a sunlit probe at 1/8000 s twice), or a
// bracket was shot with a spare frame. A bracket with them was refused whole. The later ones
// add no range: each exposure is used once, said in one line. Unless their codes differ by
// more than one exposure allows (a mean code 15 % apart; 30 % for a RAW's linear ones, half a
// stop either way): then a time is wrong, and that is refused, naming both. Returns the
// warning line, said by the caller once the bracket has passed its checks.
std::string drop_repeated_exposures(Bracket& b) {
  std::vector<std::pair<size_t, size_t>> repeats;  // (frame, the earlier frame it repeats)
  std::vector<char> dropped(b.frames.size(), 0);
  for (size_t k = 0; k < b.frames.size(); ++k)
    for (size_t j = 0; j < k; ++j)
      if (!dropped[j] && b.exposure_seconds[j] == b.exposure_seconds[k] && b.frames[j].width == b.frames[k].width &&
          b.frames[j].height == b.frames[k].height) {  // another size is check_bracket's to name
        const RgbImage &a = b.frames[j], &c = b.frames[k];
        double sum_a = 0, sum_c = 0;
        size_t n = 0;
        if (a.rgb.size() == c.rgb.size())
          for (size_t i = 0; i < a.rgb.size(); ++i) {
            const size_t px = i / 3;
            if ((!a.valid.empty() && !a.valid[px]) || (!c.valid.empty() && !c.valid[px])) continue;
            const float va = a.rgb[i], vc = c.rgb[i];
            if (!(va > 0.02f && va < 0.98f && vc > 0.02f && vc < 0.98f)) continue;
            sum_a += va, sum_c += vc, ++n;
          }
        const double apart = n * 100 >= a.rgb.size() ? std::fabs(sum_a - sum_c) / std::max(sum_a, sum_c) : 0.0;
        if (apart > (b.linear ? 0.30 : 0.15))
          throw InputError(fmt::format("{} and {}: the same exposure {} s, but their codes are {:.0f} % apart on average: "
                                       "a time is wrong (give --exposure-times)",
                                       frame_name(b, j), frame_name(b, k), b.exposure_seconds[k], 100 * apart));
        dropped[k] = 1;
        repeats.emplace_back(k, j);
        break;
      }
  if (repeats.empty()) return {};
  if (b.frames.size() - repeats.size() < 2)
    throw InputError(fmt::format("{} and {}: the same exposure time {} s, as every frame: a bracket needs at least 2 "
                                 "exposures",
                                 frame_name(b, repeats[0].second), frame_name(b, repeats[0].first), b.exposure_seconds[0]));
  std::string which;
  for (size_t r = 0; r < repeats.size() && r < 3; ++r)
    which += fmt::format("{}{} = {} ({} s)", r ? ", " : "", frame_name(b, repeats[r].first),
                         frame_name(b, repeats[r].second), b.exposure_seconds[repeats[r].first]);
  if (repeats.size() > 3) which += fmt::format(" and {} more", repeats.size() - 3);
  for (size_t k = b.frames.size(); k-- > 0;)
    if (dropped[k]) {
      b.frames.erase(b.frames.begin() + std::ptrdiff_t(k));
      b.exposure_seconds.erase(b.exposure_seconds.begin() + std::ptrdiff_t(k));
      if (k < b.paths.size()) b.paths.erase(b.paths.begin() + std::ptrdiff_t(k));
    }
  return fmt::format("{} {} the exposure of an earlier one, each exposure used once: {}", repeats.size(),
                     repeats.size() == 1 ? "frame repeats" : "frames repeat", which);
}

// "100, 400, 1600" (format: one value's text).
std::string list_of(const std::vector<ExifExposureSettings>& s, double ExifExposureSettings::*field) {
  std::string out;
  for (const auto& e : s) out += (out.empty() ? "" : ", ") + fmt::format("{:g}", e.*field);
  return out;
}

}  // namespace

void check_bracket(const Bracket& b) {
  const std::string who = b.paths.empty() ? "bracket" : b.paths.front();
  if (b.frames.size() < 2)
    throw InputError(fmt::format("{}: a bracket needs at least 2 exposures, got {}", who, b.frames.size()));
  if (b.exposure_seconds.size() != b.frames.size())
    throw InputError(fmt::format("{}: {} exposure times for {} images", who, b.exposure_seconds.size(),
                                 b.frames.size()));
  if (!b.paths.empty() && b.paths.size() != b.frames.size())
    throw InputError(fmt::format("{}: {} paths for {} images", who, b.paths.size(), b.frames.size()));
  if (b.bit_depth < 1 || b.bit_depth > 16)
    throw InputError(fmt::format("{}: unsupported bit depth {}", who, b.bit_depth));
  // The size most frames have (the first's on a tie): the frame that differs is the bad one,
  // even when it is the first.
  size_t common = 0, common_count = 0;
  for (size_t k = 0; k < b.frames.size(); ++k) {
    size_t count = 0;
    for (const RgbImage& g : b.frames) count += g.width == b.frames[k].width && g.height == b.frames[k].height;
    if (count > common_count) common = k, common_count = count;
  }
  const RgbImage& usual = b.frames[common];
  for (size_t k = 0; k < b.frames.size(); ++k) {
    const RgbImage& f = b.frames[k];
    if (f.width != usual.width || f.height != usual.height)
      throw InputError(
          (common_count > 1
               ? fmt::format("{}: size {}x{} differs from the {}x{} of {} of the {} images", frame_name(b, k), f.width,
                             f.height, usual.width, usual.height, common_count, b.frames.size())
               : fmt::format("{}: size {}x{} differs from the first image's {}x{}", frame_name(b, k), f.width,
                             f.height, usual.width, usual.height)) +
          turned_size_hint(f.width, f.height, usual.width, usual.height));
    if (f.width <= 0 || f.height <= 0 || f.rgb.size() != 3 * size_t(f.width) * size_t(f.height))
      throw InputError(fmt::format("{}: empty or malformed image", frame_name(b, k)));
    const double t = b.exposure_seconds[k];
    if (!std::isfinite(t) || !(t > 0.0))
      throw InputError(fmt::format("{}: exposure time {} s is not positive and finite", frame_name(b, k), t));
    // Two frames at one time add no range and make a response fit flat.
    for (size_t j = 0; j < k; ++j)
      if (b.exposure_seconds[j] == t)
        throw InputError(fmt::format("{} and {}: the same exposure time {} s; each frame of a bracket needs its own",
                                     frame_name(b, j), frame_name(b, k), t));
  }
  if (!b.codes.empty() && b.codes.size() != b.frames.size())
    throw InputError(fmt::format("{}: 8-bit codes of {} frames for {} images", who, b.codes.size(), b.frames.size()));
  for (size_t k = 0; k < b.codes.size(); ++k)
    if (b.codes[k].size() != b.frames[k].rgb.size())
      throw InputError(fmt::format("{}: {} 8-bit codes for {} code values", frame_name(b, k), b.codes[k].size(),
                                   b.frames[k].rgb.size()));
}

ExifExposureSettings read_exif_exposure(const std::string& path) {
  // Exiv2 is loaded by the first EXIF read (hdr/camera_files_plugin.h).
  const detail::ExifExposure e = detail::camera_files_plugin().exif_exposure(path);
  if (e.status == detail::ExifExposure::Status::Failed) throw InputError(fmt::format("{}: {}", path, e.message));
  ExifExposureSettings s;
  if (e.status == detail::ExifExposure::Status::Found) s.seconds = e.seconds;
  s.iso = e.iso;
  s.f_number = e.f_number;
  return s;
}

std::optional<double> read_exif_exposure_seconds(const std::string& path) { return read_exif_exposure(path).seconds; }

// The exposure is H = E t ISO / N^2, not E t: a bracket shot with auto ISO (phones), ISO
// bracketing or aperture bracketing changes more than the time. Read with times alone, such
// frames are fused at the wrong ratios and nothing looks wrong (a longer time is still
// brighter). Where every frame records a setting and it differs, it scales the exposure.
void fold_iso_and_aperture(Bracket& b, const std::vector<ExifExposureSettings>& s) {
  if (s.size() != b.frames.size() || s.empty()) return;
  auto all_recorded = [&](double ExifExposureSettings::*field) {
    return std::all_of(s.begin(), s.end(), [&](const auto& e) { return e.*field > 0; });
  };
  b.iso = all_recorded(&ExifExposureSettings::iso) ? s[0].iso : 0;
  b.f_number = all_recorded(&ExifExposureSettings::f_number) ? s[0].f_number : 0;
  auto varies = [&](double ExifExposureSettings::*field) {
    return std::any_of(s.begin(), s.end(), [&](const auto& e) { return std::abs(e.*field / s[0].*field - 1) > 0.01; });
  };
  const bool iso = all_recorded(&ExifExposureSettings::iso) && varies(&ExifExposureSettings::iso);
  const bool aperture = all_recorded(&ExifExposureSettings::f_number) && varies(&ExifExposureSettings::f_number);
  if (!iso && !aperture) return;
  for (size_t k = 0; k < s.size(); ++k) {
    if (iso) b.exposure_seconds[k] *= s[k].iso / s[0].iso;
    if (aperture) b.exposure_seconds[k] *= (s[0].f_number / s[k].f_number) * (s[0].f_number / s[k].f_number);
  }
  std::string what;
  if (iso) what = "ISO " + list_of(s, &ExifExposureSettings::iso);
  if (aperture) what += (iso ? " and f-numbers " : "f-numbers ") + list_of(s, &ExifExposureSettings::f_number);
  warn(fmt::format("{}: the frames' EXIF {} differ: each frame's exposure is taken as its time x ISO / f-number^2, "
                   "relative to the first",
                   b.paths.empty() ? std::string("bracket") : b.paths.front(), what));
}

namespace {

// A camera file's first `bytes` (fewer when it is shorter): what lies before its pixels.
std::string file_head(const std::string& path, size_t bytes) {
  std::ifstream in(path, std::ios::binary);
  std::string head(bytes, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(size_t(in.gcount()));
  return head;
}

bool is_tiff(const std::string& head) { return head.rfind("II*", 0) == 0 || head.rfind("MM", 0) == 0; }

// Whether a camera file may carry an ICC profile, from its first 256 KB, without Exiv2 (whose
// load costs every bracket ~5 ms): a JPEG's APP2 "ICC_PROFILE" segments and a PNG's iCCP
// chunk come before the pixels; a TIFF may hold one anywhere.
bool may_have_icc_profile(const std::string& path) {
  const std::string head = file_head(path, 256 * 1024);
  return is_tiff(head) || head.find("ICC_PROFILE") != std::string::npos || head.find("iCCP") != std::string::npos;
}

// Whether a camera file may carry EXIF, from its first 64 KB, without Exiv2: a JPEG's APP1
// "Exif" segment and a PNG's eXIf chunk come before the pixels; a TIFF is its own EXIF.
bool may_have_exif(const std::string& path) {
  const std::string head = file_head(path, 64 * 1024);
  return is_tiff(head) || head.find(std::string("Exif\0\0", 6)) != std::string::npos ||
         head.find("eXIf") != std::string::npos;
}

// A longer exposure is at least as bright in every pixel (the same scene, a monotonic
// response): where the frames say the opposite, the times given are not theirs. Sampled
// (~60,000 values a pair), so a bracket of large frames pays well under a millisecond.
void check_exposure_order(const Bracket& b, const char* times_from) {
  std::vector<size_t> order(b.frames.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(), [&](size_t i, size_t j) { return b.exposure_seconds[i] < b.exposure_seconds[j]; });
  for (size_t k = 0; k + 1 < order.size(); ++k) {
    const size_t s = order[k], l = order[k + 1];
    const std::vector<float>& shorter = b.frames[s].rgb;
    const std::vector<float>& longer = b.frames[l].rgb;
    const size_t stride = std::max<size_t>(1, shorter.size() / 60000);
    size_t brighter = 0, darker = 0, compared = 0, equal = 0, well = 0, up = 0, down = 0;
    for (size_t i = 0; i < shorter.size(); i += stride) {
      const float a = shorter[i], c = longer[i];
      if ((a >= 0.98f && c >= 0.98f) || (a <= 0.02f && c <= 0.02f)) continue;  // clipped in both alike
      ++compared;
      equal += std::fabs(c - a) < 0.5f / 255;  // the same 8-bit code (Memorial's pairs: at most 38 %)
      brighter += c > a + 0.02f;
      darker += c < a - 0.02f;
      // Where the longer frame is well exposed, half a stop more raises even a gamma-encoded
      // code by a tenth; flat fog (a film scan's shadows) moves by noise alone.
      if (c < 0.25f || c > 0.95f) continue;
      ++well;
      up += c > a + 1.5f / 255;  // any change beyond an 8-bit code's rounding
      down += c < a - 1.5f / 255;
    }
    if (darker >= 1000 && darker > 4 * brighter)
      throw InputError(fmt::format("{} ({} s) is darker than {} ({} s) in {} % of the sampled values they both "
                                   "expose: the exposure times {} are not these frames' (another order?)",
                                   frame_name(b, l), b.exposure_seconds[l], frame_name(b, s), b.exposure_seconds[s],
                                   int(std::lround(100.0 * double(darker) / double(darker + brighter))), times_from));
    // Half a stop longer, yet equal, or its well-exposed values no more often brighter than darker: the
    // same picture twice (a bracket that did not fire, a file listed twice under two times),
    // identical or differing by noise alone. Fused, it halved the map where it counted.
    const bool longer_by_half_a_stop = b.exposure_seconds[l] >= 1.5 * b.exposure_seconds[s];
    if (longer_by_half_a_stop && compared >= 1000 && equal * 10 >= compared * 9)
      throw InputError(fmt::format("{} ({} s) and {} ({} s) are the same picture: {} % of the values they both expose "
                                   "are equal (the same file twice, or a bracket that did not change exposure?)",
                                   frame_name(b, l), b.exposure_seconds[l], frame_name(b, s), b.exposure_seconds[s],
                                   int(std::lround(100.0 * double(equal) / double(compared)))));
    if (longer_by_half_a_stop && well >= 200 && up <= 2 * down + well / 10)
      throw InputError(fmt::format("{} ({} s) and {} ({} s) are the same picture: where the longer is well exposed it "
                                   "is brighter in {} % of the values, darker in {} % (a bracket that did not change "
                                   "exposure?)",
                                   frame_name(b, l), b.exposure_seconds[l], frame_name(b, s), b.exposure_seconds[s],
                                   int(std::lround(100.0 * double(up) / double(well))),
                                   int(std::lround(100.0 * double(down) / double(well)))));
  }
}

}  // namespace

std::optional<ColourProfile> read_colour_profile(const std::string& path) {
  if (!may_have_icc_profile(path)) return std::nullopt;
  const std::string icc = detail::camera_files_plugin().icc_profile(path);
  if (icc.empty()) return std::nullopt;
  const auto summary = summarize_icc_profile(icc);
  if (summary && summary->srgb) return std::nullopt;
  const std::string name = summary && !summary->description.empty() ? summary->description
                           : summary                                ? "no description"
                                                                    : "unreadable";
  if (summary && summary->has_colorants) return ColourProfile{name, icc_colorants_to_rec709(*summary, path.c_str())};
  static std::mutex mutex;
  static std::set<std::string> warned;
  {
    std::lock_guard lock(mutex);
    if (!warned.insert(name).second) return std::nullopt;
  }
  warn(fmt::format("{}: its ICC profile ('{}') is not applied: its colours are taken as sRGB", path, name));
  return std::nullopt;
}

Bracket read_bracket(const std::vector<std::string>& paths, const std::optional<std::vector<double>>& times) {
  Bracket b;
  std::vector<ExifExposureSettings> settings;  // each frame's recorded ISO and f-number
  bool first_grey = false;                      // the first camera image's colour mode
  std::vector<int> orientation;                 // each camera image's EXIF Orientation
  if (times && times->size() != paths.size())
    throw InputError(fmt::format("--exposure-times: {} times for {} images", times->size(), paths.size()));
  // Camera RAW files (through LibRaw) are linear 16-bit with their own shutter time.
  const auto is_raw = is_camera_raw_file;
  for (size_t k = 0; k < paths.size(); ++k) {
    for (size_t j = 0; j < k; ++j) {
      std::error_code ec;
      if (paths[j] == paths[k] || fs::equivalent(paths[j], paths[k], ec))
        throw InputError(fmt::format("{}: given twice (as image {} and {}): each frame of a bracket is its own photo",
                                     paths[k], j + 1, k + 1));
    }
    if (is_raw(paths[k])) {
      RawExposure raw;
      RgbImage f = read_camera_raw(paths[k], &raw);  // as stored, turned below as JPEGs are
      orientation.push_back(raw.orientation);
      f.orientation = 1;
      const double t = raw.seconds;
      ExifExposureSettings e;  // the same fold as for EXIF: a RAW bracket may vary its ISO too
      e.iso = raw.iso, e.f_number = raw.f_number;
      settings.push_back(e);
      if (k > 0 && !b.linear) throw InputError(fmt::format("{}: a RAW file in a bracket of non-RAW images", paths[k]));
      b.linear = true;
      b.bit_depth = 16;
      b.frames.push_back(std::move(f));
      b.paths.push_back(paths[k]);
      if (times) b.exposure_seconds.push_back((*times)[k]);
      else if (t > 0) b.exposure_seconds.push_back(t);
      else throw InputError(paths[k] + ": no shutter time in the RAW file; give --exposure-times");
      continue;
    }
    if (b.linear) throw InputError(fmt::format("{}: a non-RAW image in a bracket of RAW files", paths[k]));
    // As stored: turned below, once every frame's EXIF Orientation is known.
    CameraImage cam = read_camera_image(paths[k], true);
    orientation.push_back(cam.orientation);
    if (k == 0) {
      b.bit_depth = cam.bit_depth;
      first_grey = cam.grey;
    } else if (cam.bit_depth != b.bit_depth) {
      throw InputError(fmt::format("{}: {}-bit image in a bracket of {}-bit images", paths[k], cam.bit_depth,
                                   b.bit_depth));
    } else if (cam.grey != first_grey) {  // merged, its grey would tint the pixels it exposes best
      throw InputError(fmt::format("{}: a {} image in a bracket of {} images (one camera, one colour mode)", paths[k],
                                   cam.grey ? "grey" : "colour", first_grey ? "grey" : "colour"));
    }
    RgbImage f;
    f.width = cam.width;
    f.height = cam.height;
    f.rgb = std::move(cam.rgb);
    f.mirror_ball = cam.mirror_ball;
    if (!cam.valid.empty()) {  // transparent pixels: no data in this frame, merged from the others
      const auto none = size_t(std::count(cam.valid.begin(), cam.valid.end(), uint8_t(0)));
      warn(fmt::format("{}: {} pixels ({:.3g} %) have alpha below half: no data there (left out of this frame), not black",
                       paths[k], none, 100.0 * double(none) / double(cam.valid.size())));
      f.valid = std::move(cam.valid);
    }
    b.frames.push_back(std::move(f));
    b.paths.push_back(paths[k]);
    if (times) {
      b.exposure_seconds.push_back((*times)[k]);
      // Given times are times: the ISO and aperture still count, where EXIF has them. A file
      // whose EXIF cannot be read was given its time, so that is no error here.
      ExifExposureSettings e;
      if (may_have_exif(paths[k])) {
        try {
          e = read_exif_exposure(paths[k]);
        } catch (const InputError&) {
        }
      }
      // A given time a third of a stop or more from the photo's own: said, then used (a
      // typo, or another bracket's list; the order check cannot see a wrong ratio).
      if (e.seconds && *e.seconds > 0 && (*times)[k] > 0) {
        const double stops = std::log2((*times)[k] / *e.seconds);
        if (std::fabs(stops) >= 1.0 / 3.0)
          warn(fmt::format("{}: --exposure-times gives {} s, its EXIF {} s ({:+.1f} stops); the given time is used",
                           paths[k], (*times)[k], *e.seconds, stops));
      }
      settings.push_back(e);
    } else {
      settings.push_back(read_exif_exposure(paths[k]));
      if (!settings.back().seconds) throw InputError(paths[k] + ": no exposure time in EXIF; give --exposure-times");
      b.exposure_seconds.push_back(*settings.back().seconds);
    }
  }
  // The frames of one bracket come from one camera that did not turn between them: shown as
  // their EXIF Orientation says where they agree, as stored where they do not. A camera
  // pointing up (a fisheye sky bracket) records an arbitrary orientation per frame, and frames
  // tagged upside down among upright ones were merged turned 180 degrees against the others.
  std::vector<std::string> said;  // after the checks: a refused bracket says one line
  if (!orientation.empty()) {
    if (std::all_of(orientation.begin(), orientation.end(), [&](int o) { return o == orientation[0]; })) {
      for (RgbImage& f : b.frames) {
        CameraImage c;
        c.width = f.width, c.height = f.height, c.rgb = std::move(f.rgb), c.valid = std::move(f.valid);
        c.mirror_ball = f.mirror_ball;
        c = turned_as_shown(std::move(c), orientation[0]);
        f.width = c.width, f.height = c.height, f.rgb = std::move(c.rgb), f.valid = std::move(c.valid);
        f.mirror_ball = c.mirror_ball;
      }
      b.orientation = orientation[0];
    } else {
      std::string list;
      for (size_t k = 0; k < orientation.size(); ++k) list += (k ? ", " : "") + std::to_string(orientation[k]);
      said.push_back(fmt::format("{}: the frames' EXIF Orientation disagree ({}): one camera did not turn between the "
                                 "frames of a bracket, so they are read as stored",
                                 paths[0], list));
    }
  }
  fold_iso_and_aperture(b, settings);
  if (std::string line = drop_repeated_exposures(b); !line.empty()) said.push_back(std::move(line));
  check_bracket(b);
  // Photos registered together (probe register) record one ball; frames that record none or
  // another were not, and their fused image records none, said.
  const auto& first_ball = b.frames[0].mirror_ball;
  const bool one_ball = std::all_of(b.frames.begin(), b.frames.end(), [&](const RgbImage& f) {
    return f.mirror_ball == first_ball;
  });
  if (one_ball) {
    b.mirror_ball = first_ball;
  } else {
    said.push_back(fmt::format("{}: the frames do not record one mirror ball (probe register records where it put "
                               "the ball; these were not registered together): the fused image records none",
                               paths[0]));
  }
  apply_sensor_white_level(b);
  check_exposure_order(b, times ? "given (--exposure-times)" : "read from the files");
  for (const std::string& line : said) warn(line);
  if (!b.linear) {  // after the checks: a refused bracket says one line
    if (auto profile = read_colour_profile(paths[0])) b.to_rec709 = profile->to_rec709, b.colour_profile = profile->name;
  }
  if (b.bit_depth == 8 && !b.linear) keep_8bit_codes(b);
  return b;
}

double reference_exposure_scale(const Bracket& b) {
  return (b.iso > 0 ? 100.0 / b.iso : 1.0) * (b.f_number > 0 ? b.f_number * b.f_number : 1.0);
}

void apply_sensor_white_level(Bracket& b) {
  // core/sensor_white_level.h: measured on a synthetic 12-bit bracket, the fused map's
  // brightest pixel came out at 1/900 of the truth's, with exit 0, before this.
  if (b.bit_depth != 16 || b.linear || b.frames.empty()) return;
  std::vector<const std::vector<float>*> frames;
  for (const RgbImage& f : b.frames) frames.push_back(&f.rgb);
  const SensorWhiteLevel level = find_sensor_white_level(frames);
  if (!level.code) return;
  for (RgbImage& f : b.frames) read_at_white_level(f.rgb, level.code);
  b.white_level = int(level.code);
  warn(fmt::format("{}: the 16-bit codes of all {} frames stop at {}, {} values clipped there: read as a {}-bit "
                   "sensor's codes, white level {}",
                   b.paths.empty() ? std::string("bracket") : b.paths.front(), b.frames.size(), level.code,
                   level.at_top, white_level_bits(level.code), level.code));
}

void keep_8bit_codes(Bracket& b) {
  b.codes.resize(b.frames.size());
  for (size_t k = 0; k < b.frames.size(); ++k) {
    const std::vector<float>& v = b.frames[k].rgb;
    std::vector<uint8_t>& out = b.codes[k];
    out.resize(v.size());
    for (size_t i = 0; i < v.size(); ++i) {
      const float s = v[i] * 255.0f + 0.5f;  // as merge.cpp's level_of
      out[i] = s > 0.0f ? uint8_t(std::min(s, 255.0f)) : uint8_t(0);
    }
  }
}

std::vector<ExposureEntry> read_exposure_entries(const std::string& path) {
  std::istringstream in(read_text_file(path, "the exposure list"));
  std::vector<ExposureEntry> entries;
  std::string line;
  int line_no = 0;
  bool first_data_line = true;
  while (std::getline(in, line)) {
    ++line_no;
    line = trim_blanks(line);
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields;
    if (line.find(',') != std::string::npos) {
      std::stringstream ss(line);
      std::string f;
      while (std::getline(ss, f, ',')) fields.push_back(trim_blanks(f));
    } else {
      std::istringstream ss(line);
      std::string f;
      while (ss >> f) fields.push_back(f);
    }
    ExposureEntry e;
    e.line = line_no;
    std::optional<double> t = parse_seconds(fields[0]);
    if (!t && fields.size() >= 2) {
      t = parse_seconds(fields[1]);
      e.file = fields[0];
    }
    const bool header = first_data_line && !t;
    first_data_line = false;
    if (header) {
      // Times are seconds (CONVENTIONS.md): a header naming another unit is refused, not
      // skipped (exposure_ms read as seconds made the map 1000x too dark).
      for (const std::string& f : fields) {
        std::string name = f;
        std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
        for (const char* unit : {"ms", "msec", "milli", "us", "usec", "micro", "\xc2\xb5s", "ns", "nano"})
          if (name == unit || name.find(std::string("_") + unit) != std::string::npos ||
              name.find(std::string("(") + unit) != std::string::npos || name.find(std::string("[") + unit) != std::string::npos ||
              (std::string_view(unit).size() > 2 && name.find(unit) != std::string::npos))
            throw InputError(fmt::format("{}:{}: the header '{}' names its times in another unit than seconds; write "
                                         "them in seconds (1/250 or 0.004)",
                                         path, line_no, line));
      }
      continue;
    }
    if (!t) throw InputError(fmt::format("{}:{}: no exposure time in '{}'", path, line_no, line));
    if (!std::isfinite(*t) || !(*t > 0.0))
      throw InputError(fmt::format("{}:{}: exposure time {} s is not positive and finite", path, line_no, *t));
    e.seconds = *t;
    entries.push_back(std::move(e));
  }
  if (entries.empty()) throw InputError(path + ": no exposure times in the file");
  return entries;
}

std::vector<double> read_exposure_list(const std::string& path) {
  std::vector<double> times;
  for (const ExposureEntry& e : read_exposure_entries(path)) times.push_back(e.seconds);
  return times;
}

std::vector<double> exposure_times_for(const std::string& path, const std::vector<std::string>& images) {
  const std::vector<ExposureEntry> entries = read_exposure_entries(path);
  const size_t named = size_t(std::count_if(entries.begin(), entries.end(), [](const auto& e) { return !e.file.empty(); }));
  if (named == 0) {
    if (entries.size() != images.size())
      throw InputError(fmt::format("{}: {} times for {} images (a list of times alone is read in order)", path,
                                   entries.size(), images.size()));
    std::vector<double> times;
    for (const ExposureEntry& e : entries) times.push_back(e.seconds);
    return times;
  }
  if (named != entries.size()) {
    const auto bare = std::find_if(entries.begin(), entries.end(), [](const auto& e) { return e.file.empty(); });
    throw InputError(fmt::format("{}:{}: a time without a file name in a list that names its files", path, bare->line));
  }
  // Glob order is not the list's order (ball_1-160s.jpg sorts before ball_1-40s.jpg), and a
  // subset of a bracket is a bracket: names, not positions, say which time is whose.
  // Matched on the path as given, else the file name, else the stem: a photo converted or
  // registered to PNG (probe register) keeps its name but not its extension.
  std::vector<double> times;
  for (const std::string& image : images) {
    const fs::path p(image);
    const ExposureEntry* found = nullptr;
    for (const int tier : {0, 1, 2}) {
      for (const ExposureEntry& e : entries) {
        const fs::path q(e.file);
        const bool match = tier == 0   ? e.file == image
                           : tier == 1 ? q.filename() == p.filename()
                                       : q.stem() == p.stem();
        if (!match) continue;
        if (found)
          throw InputError(fmt::format("{}: lines {} and {} both name {}", path, found->line, e.line, image));
        found = &e;
      }
      if (found) break;
    }
    if (!found) throw InputError(fmt::format("{}: no line names {} (the list names its files)", path, image));
    times.push_back(found->seconds);
  }
  return times;
}

}  // namespace lp
