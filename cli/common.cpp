// The helpers the command handlers share (cli/commands.h).
#include "cli/commands.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "calib/board_detect.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/limits.h"
#include "eval/synthetic_sequence.h"
#include "hdr/response.h"
#include "hdr/synthetic_bracket.h"
#include "render/reference_shader.h"
#include "sampling/light_units.h"

namespace lp::cli {

void parse_size(const std::string& text, const char* option, int* width, int* height) {
  int w = 0, h = 0;
  char x = 0, extra = 0;
  std::istringstream in(text);
  if (!(in >> w >> x >> h) || (x != 'x' && x != 'X') || (in >> extra) || w <= 0 || h <= 0)
    throw InputError(fmt::format("{} must be WxH with positive integers, got '{}'", option, text));
  *width = w;
  *height = h;
}

void parse_image_size(const std::string& text, const char* option, int* width, int* height) {
  parse_size(text, option, width, height);
  check_image_size(option, *width, *height, "size");
}

void check_frame_count(const char* option, long long count) {
  check_count(option, count, limits().max_frames, "frames", "each is a file or a map held");
}

std::vector<int> parse_light_counts(const std::string& text, const char* option) {
  std::vector<int> counts = parse_int_list(text, option);
  for (int n : counts) check_light_count(option, n);
  return counts;
}

std::vector<int> parse_int_list(const std::string& text, const char* option) {
  std::vector<int> values;
  std::istringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      size_t used = 0;
      const int v = std::stoi(item, &used);
      if (used != item.size() || v <= 0) throw std::invalid_argument("x");
      values.push_back(v);
    } catch (const std::exception&) {
      throw InputError(fmt::format("{} must be a comma-separated list of positive integers, got '{}'", option, text));
    }
  }
  if (values.empty()) throw InputError(fmt::format("{} is empty", option));
  return values;
}

Mat3 parse_rotation(const std::string& text) {
  const std::vector<double> v = parse_numbers(text, "--rotation");
  if (v.size() == 3) return rotation_from_yaw_pitch_roll_deg(v[0], v[1], v[2]);
  if (v.size() == 9) {
    Mat3 m;
    std::copy(v.begin(), v.end(), m.m.begin());
    if (!is_rotation(m, 1e-4)) throw InputError("--rotation: the 9 numbers are not a rotation matrix");
    // Typed to four or five decimals it is a rotation only to 1e-4: the nearest exact one is
    // what the unwrappers need (they check to 1e-6) and what the map records.
    return nearest_rotation(m);
  }
  throw InputError("--rotation takes 'yaw,pitch,roll' (degrees) or 9 comma-separated numbers");
}

std::optional<Layout> optional_layout(const std::string& name, const char* option) {
  if (name.empty()) return std::nullopt;
  auto l = layout_from_string(name);
  if (!l) throw InputError(fmt::format("{}: unknown layout '{}' (latlong, hemisphere, healpix)", option, name));
  return l;
}

int given_nside(int nside) {
  if (nside < 0) throw InputError(fmt::format("--nside must be a power of two (0: the default), got {}", nside));
  if (nside > 0) check_nside("--nside", nside);
  return nside;
}

void check_target_flags(const std::string& size, int nside) {
  int w = 0, h = 0;
  if (!size.empty()) parse_image_size(size, "--size", &w, &h);
  given_nside(nside);
}

void refuse_misplaced_geometry(Layout layout, const std::string& size, int nside) {
  if (layout == Layout::Healpix && !size.empty()) throw InputError("--size does not apply to healpix: use --nside");
  if (layout != Layout::Healpix && nside != 0) throw InputError("--nside applies only to --layout healpix");
}

// Target (layout, width, height) of convert/synth from --layout/--size/--nside.
void target_geometry(Layout layout, const std::string& size, int nside, const EnvMap* like, int* w, int* h) {
  if (layout == Layout::Healpix) {
    given_nside(nside);
    *w = nside > 0 ? nside : (like && like->layout == Layout::Healpix ? like->nside : 0);
    if (*w == 0) {
      // About as many pixels as the source.
      const double px = like ? double(like->pixel_count()) : 12.0 * 64 * 64;
      *w = 1;
      while (12.0 * (2 * *w) * (2 * *w) <= px * 1.5) *w *= 2;
    }
    *h = 1;
    return;
  }
  if (!size.empty()) {
    parse_image_size(size, "--size", w, h);
    return;
  }
  if (like && like->layout == layout) {
    *w = like->width;
    *h = like->height;
    return;
  }
  if (layout == Layout::Hemisphere) {
    *w = 360;
    *h = 90;
    return;
  }
  // latlong with about as many pixels as the source
  const double px = like ? double(like->pixel_count()) : 1024.0 * 512;
  *h = std::max(2, int(std::lround(std::sqrt(px / 2))));
  *w = 2 * *h;
}

int light_count(const std::string& text) {
  if (text == "auto") return 0;
  int n = 0;
  try {
    size_t used = 0;
    n = std::stoi(text, &used);
    if (used != text.size()) throw std::invalid_argument("x");
  } catch (const std::exception&) {
    throw InputError(fmt::format("--n must be a positive integer or 'auto', got '{}'", text));
  }
  if (n <= 0) throw InputError(fmt::format("--n must be positive, got {}", n));
  check_light_count("--n", n);
  return n;
}

std::vector<double> parse_numbers(const std::string& text, const char* option, size_t count) {
  std::vector<double> v;
  // Split keeping empty items: "0.5," and "1,,2" were read as "0.5" and "1,2".
  std::vector<std::string> items;
  for (size_t start = 0;;) {
    const size_t comma = text.find(',', start);
    items.push_back(text.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (text.empty()) items.clear();
  for (std::string item : items) {
    item = trim_blanks(item);
    try {
      size_t used = 0;
      // Fractions such as 1/40 are common for exposure times.
      const auto slash = item.find('/');
      double x;
      if (slash != std::string::npos) {
        size_t u2 = 0;
        const std::string a = item.substr(0, slash), b = item.substr(slash + 1);
        x = std::stod(a, &used) / std::stod(b, &u2);
        if (used != a.size() || u2 != b.size()) throw std::invalid_argument("x");
      } else {
        x = std::stod(item, &used);
        if (used != item.size()) throw std::invalid_argument("x");
      }
      if (!std::isfinite(x)) throw std::invalid_argument("x");
      v.push_back(x);
    } catch (const std::exception&) {
      throw InputError(fmt::format("{}: '{}' is not a number", option, item));
    }
  }
  if (v.empty() || (count && v.size() != count))
    throw InputError(count ? fmt::format("{} takes {} comma-separated numbers, got '{}'", option, count, text)
                           : fmt::format("{} is empty", option));
  return v;
}

ResponseCurve curve_from(const std::string& name) {
  if (name == "linear") return ResponseCurve::Linear;
  if (name == "gamma") return ResponseCurve::Gamma22;
  if (name == "scurve") return ResponseCurve::SCurve;
  throw InputError(fmt::format("--response must be linear, gamma or scurve, got '{}'", name));
}

std::vector<std::string> split_commas(const std::string& text) {
  std::vector<std::string> items;
  size_t start = 0;
  while (start <= text.size()) {
    const size_t comma = std::min(text.find(',', start), text.size());
    items.push_back(text.substr(start, comma - start));
    start = comma + 1;
  }
  return items;
}

std::vector<Method> parse_method_list(const std::string& text) {
  if (text == "all") return all_methods();
  std::vector<Method> methods;
  for (const std::string& name : split_commas(text)) {
    auto m = method_from_string(name);
    if (!m) throw InputError(fmt::format("--methods: unknown method '{}' (pharr, hemigon, q2tree, mediancut, all)", name));
    methods.push_back(*m);
  }
  return methods;
}

std::vector<Scenario> parse_scenarios(const std::string& text) {
  if (text == "all") return all_scenarios();
  std::vector<Scenario> scenarios;
  for (const std::string& name : split_commas(text)) {
    auto s = scenario_from_string(name);
    if (!s) {
      std::string known;
      for (Scenario k : all_scenarios()) known += (known.empty() ? "" : ", ") + std::string(to_string(k));
      throw InputError(fmt::format("--scenarios: unknown scenario '{}' ({})", name, known));
    }
    scenarios.push_back(*s);
  }
  return scenarios;
}

BoardSpec board_from(const std::string& text, double square_mm) {
  int cols = 0, rows = 0;
  parse_size(text, "--board", &cols, &rows);
  // The detectors need 3 a side, and a 2-corner axis shows no distortion: 2x2 solved to
  // infinite held-out errors with exit 0.
  if (cols < 3 || rows < 3) throw InputError(fmt::format("--board counts inner corners and needs at least 3x3, got {}", text));
  if (!(square_mm > 0) || !std::isfinite(square_mm)) throw InputError("--square must be a positive finite size (mm)");
  return BoardSpec{cols, rows, square_mm};
}

void declare_table_options(Flags& f, ShadingTableArgs& t) {
  f.opt("--method", t.method, "Progressive sampler for the lights: pharr|hemigon");
  f.opt("--low-per-high", t.low_per_high, "|L| / |H|: dense lights per glossy-cone light");
  f.opt("--regions", t.regions, "Culling regions (S_H)");
  f.opt("--cone-regions", t.cone_regions, "Glossy-cone regions (S_L)");
  f.opt("--lut", t.lut, "Cube-map LUT texels per face edge");
  f.opt("--cone", t.cone_deg, "Cone half-angle around the reflected direction, degrees");
  f.opt("--k", t.k, "At most this many L lights per cone (power rescaled)");
  f.opt("--q", t.q, "Cluster to at most Q lights (0: |H| / 4)");
}

ShadingOptions shading_options(const ShadingTableArgs& a) {
  if (a.regions < 1) throw InputError(fmt::format("--regions must be at least 1, got {}", a.regions));
  if (a.cone_regions < 1) throw InputError(fmt::format("--cone-regions must be at least 1, got {}", a.cone_regions));
  if (a.lut < 1) throw InputError(fmt::format("--lut must be at least 1, got {}", a.lut));
  if (a.low_per_high < 1) throw InputError(fmt::format("--low-per-high must be at least 1, got {}", a.low_per_high));
  if (a.k < 1) throw InputError(fmt::format("--k must be at least 1, got {}", a.k));
  if (a.q < 0) throw InputError(fmt::format("--q must be at least 1 (or 0 for |H| / 4), got {}", a.q));
  check_count("--lut", a.lut, limits().max_lut, "texels a face edge", "the LUT is built texel by texel and exported");
  // A region needs a texel: more regions than the LUT has texels are empty and only cost time.
  const long long texels = 6LL * a.lut * a.lut;
  check_count("--regions", a.regions, texels, "regions", "the 6 lut^2 texels of the LUT");
  check_count("--cone-regions", a.cone_regions, texels, "regions", "the 6 lut^2 texels of the LUT");
  check_light_count("--n", a.n);
  check_light_count("--low-per-high", (long long)a.n * a.low_per_high);
  if (!(a.cone_deg > 0 && a.cone_deg <= 90))
    throw InputError(fmt::format("--cone must be in (0, 90] degrees, got {}", a.cone_deg));
  ShadingOptions o;
  o.regions = {a.regions, a.lut};
  o.glossy.low_per_high = a.low_per_high;
  o.glossy.cone_half_angle_deg = a.cone_deg;
  o.glossy.max_cone_lights = a.k;
  o.glossy.cone_regions = {a.cone_regions, a.lut};
  o.cluster_max_lights = a.q;
  o.region_copies = a.region_copies;
  return o;
}

Method progressive_method(const std::string& name) {
  auto m = method_from_string(name);
  if (!m || (*m != Method::Pharr && *m != Method::Hemigon))
    throw InputError(fmt::format("--method: '{}' is not a progressive sampler (pharr or hemigon)", name));
  return *m;
}

void UnitFlags::declare(Flags& f) {
  f.opt("--exposure", exposure, "Scale a relative map's products by 2^EV (then written as absolute units)");
  f.opt("--scale", scale, "Scale by K: relative units -> W sr^-1 m^-2");
  f.opt("--normalize-illuminance", normalize_illuminance, "Scale so an upward-facing surface gets LUX");
}

LightUnitsOptions UnitFlags::options() const {
  LightUnitsOptions u;
  if (!exposure.empty()) u.exposure_ev = parse_numbers(exposure, "--exposure", 1)[0];
  if (!scale.empty()) u.scale = parse_numbers(scale, "--scale", 1)[0];
  if (!normalize_illuminance.empty())
    u.normalize_illuminance_lux = parse_numbers(normalize_illuminance, "--normalize-illuminance", 1)[0];
  return u;
}

CodeCurve code_curve(const std::string& codes) {
  CodeCurve c;
  c.name = codes;
  if (codes == "srgb") return c;
  if (codes == "linear") {
    c.kind = CodeCurve::Kind::Linear;
    return c;
  }
  if (!std::filesystem::exists(codes))
    throw InputError(fmt::format("--codes: '{}' is neither srgb, linear nor a response file", codes));
  return response_code_curve(load_response(codes).log_exposure, codes);
}

}  // namespace lp::cli
