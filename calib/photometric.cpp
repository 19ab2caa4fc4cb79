#include "calib/photometric.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "calib/ceres_plugin.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/json_file.h"

namespace lp {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string where(const PhotometricReading& r) {
  if (!r.source.empty()) return r.source;
  return "reading '" + r.label + "'";
}


std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

// Splits one CSV line; fields may be double-quoted ("" is a quote inside quotes).
std::vector<std::string> split_csv(const std::string& line, const std::string& at) {
  std::vector<std::string> fields;
  std::string field;
  bool quoted = false, was_quoted = false;
  for (size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        field += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        field += c;
      }
    } else if (c == '"' && trim_blanks(field).empty()) {
      quoted = was_quoted = true;
      field.clear();
    } else if (c == ',') {
      fields.push_back(was_quoted ? field : trim_blanks(field));
      field.clear();
      was_quoted = false;
    } else {
      field += c;
    }
  }
  if (quoted) throw InputError(at + ": unterminated quote");
  fields.push_back(was_quoted ? field : trim_blanks(field));
  return fields;
}

bool parse_int(const std::string& s, int* out) {
  const std::string t = trim_blanks(s);
  if (t.empty()) return false;
  auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), *out);
  return ec == std::errc() && p == t.data() + t.size();
}

double parse_number(const std::string& s, const std::string& what, const std::string& at) {
  const std::string t = trim_blanks(s);
  double v = 0;
  auto [p, ec] = std::from_chars(t.data(), t.data() + t.size(), v);
  if (t.empty() || ec != std::errc() || p != t.data() + t.size())
    throw InputError(at + ": " + what + " '" + t + "' is not a number");
  if (!std::isfinite(v)) throw InputError(at + ": " + what + " '" + t + "' is not finite");
  if (v <= 0) throw InputError(at + ": " + what + " " + t + " is not positive");
  return v;
}

std::optional<PhotometricReading::Unit> parse_unit(const std::string& text) {
  std::string u = lower(trim_blanks(text));
  if (u == "cd/m2" || u == "cd/m^2" || u == "cd m-2" || u == "cd/m²" || u == "nit" || u == "nits")
    return PhotometricReading::Unit::CandelaPerSquareMetre;
  if (u == "lux" || u == "lx") return PhotometricReading::Unit::Lux;
  return std::nullopt;
}

// "image.exr:x,y,w,h" -> region; a label without ':' followed by a comma is a plain label.
std::optional<ImageRegion> parse_region(const std::string& label, const std::string& at) {
  const size_t colon = label.rfind(':');
  if (colon == std::string::npos || label.find(',', colon) == std::string::npos) return std::nullopt;
  ImageRegion region;
  region.image = label.substr(0, colon);
  std::vector<std::string> parts;
  std::stringstream ss(label.substr(colon + 1));
  for (std::string part; std::getline(ss, part, ',');) parts.push_back(part);
  if (region.image.empty() || parts.size() != 4 || !parse_int(parts[0], &region.x) ||
      !parse_int(parts[1], &region.y) || !parse_int(parts[2], &region.width) ||
      !parse_int(parts[3], &region.height))
    throw InputError(at + ": region '" + label + "' is not image:x,y,w,h");
  if (region.x < 0 || region.y < 0 || region.width <= 0 || region.height <= 0)
    throw InputError(at + ": region '" + label + "' needs x, y >= 0 and w, h > 0");
  return region;
}

const char* loss_name(RobustLoss loss) {
  switch (loss) {
    case RobustLoss::None: return "none";
    case RobustLoss::Huber: return "huber";
    case RobustLoss::Cauchy: return "cauchy";
  }
  return "none";
}

double median(std::vector<double> v) {
  const size_t n = v.size();
  std::sort(v.begin(), v.end());
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct Fit {
  std::vector<double> params;  // {ln k} or {a, b}
  std::vector<double> sigma;   // standard errors of params
};

// Robust fit over readings[i] for i in `use`; with_covariance adds standard errors.
Fit solve(const std::vector<PhotometricReading>& readings, const std::vector<size_t>& use,
          const PhotometricOptions& options, bool with_covariance) {
  const bool log_model = options.model == PhotometricOptions::Model::LogSensor;
  Fit fit;
  // Robust start: median log ratio (linear); Theil-Sen line of v on ln L (log sensor).
  if (!log_model) {
    std::vector<double> ratios;
    for (size_t i : use) ratios.push_back(std::log(readings[i].measured / readings[i].camera_value));
    fit.params = {median(ratios)};
  } else {
    std::vector<double> slopes;
    for (size_t i = 0; i < use.size(); ++i)
      for (size_t j = i + 1; j < use.size(); ++j) {
        const double dx = std::log(readings[use[j]].measured) - std::log(readings[use[i]].measured);
        if (std::abs(dx) > 1e-12) slopes.push_back((readings[use[j]].camera_value - readings[use[i]].camera_value) / dx);
      }
    if (slopes.empty()) throw InputError("photometric readings: every measured luminance is the same; a log-sensor fit needs different ones");
    const double b = median(slopes);
    if (b == 0) throw InputError("photometric readings: camera values do not change with luminance; a log-sensor fit needs them to");
    std::vector<double> offsets;
    for (size_t i : use) offsets.push_back(readings[i].camera_value - b * std::log(readings[i].measured));
    fit.params = {median(offsets), b};
  }

  // The robust fit itself runs in the Ceres plugin (calib/ceres_plugin.h): Huber or Cauchy
  // loss, dense QR, tolerances 1e-16; Ceres is loaded by the first fit.
  std::vector<double> a, b;
  for (size_t i : use) {
    const auto& r = readings[i];
    a.push_back(log_model ? r.camera_value : std::log(r.camera_value));
    b.push_back(std::log(r.measured));
  }
  const size_t p = fit.params.size();
  std::vector<double> cov(p * p);
  static_assert(int(RobustLoss::None) == 0 && int(RobustLoss::Huber) == 1 && int(RobustLoss::Cauchy) == 2,
                "CeresPhotometricFit::loss numbers the losses so");
  detail::CeresPhotometricFit problem;
  problem.log_sensor = log_model;
  problem.loss = int(options.loss);
  problem.loss_scale = options.loss_scale;
  problem.a = a.data();
  problem.b = b.data();
  problem.count = use.size();
  problem.params = fit.params.data();
  problem.with_covariance = with_covariance;
  problem.covariance = cov.data();
  const detail::CeresPhotometricSummary summary = detail::ceres_plugin().fit_photometric(problem);
  if (!summary.usable) throw std::runtime_error("photometric fit failed: " + summary.brief_report);

  fit.sigma.assign(p, 0.0);
  if (with_covariance) {
    // Ceres' covariance assumes unit-variance residuals: scaled by s^2 = 2 cost / (n - p).
    const double dof = double(use.size()) - double(p);
    const double s2 = dof > 0 ? 2 * summary.final_cost / dof : 0.0;
    if (summary.covariance_ok) {
      for (size_t k = 0; k < p; ++k) fit.sigma[k] = std::sqrt(std::max(0.0, cov[k * p + k] * s2));
    } else {
      fit.sigma.assign(p, std::numeric_limits<double>::infinity());
    }
  }
  return fit;
}

// Leave-one-out estimates of ln k for the linear model with no loss or a Huber loss, all n
// in O(n log n) (a Ceres fit per reading made `calib photometric` quadratic: 20,000 rows took
// minutes). With c_i = ln camera_i - ln measured_i the residual is theta + c_i, and the fit is
// the root of the nondecreasing, piecewise linear F(theta) = sum_i psi(theta + c_i), psi the
// identity clipped to +-scale (Huber; unclipped for no loss), convex cost so one root.
// Over the c_i sorted once, with prefix sums, F without reading i costs two binary searches;
// the root is found on its linear piece: from the full fit's piece, re-solved until the
// piece holds it (one or two steps, as one reading moves the fit by O(1/n)).
// Empty when the loss is not one of those (Cauchy is not convex: Ceres per reading).
std::vector<double> held_out_linear_fast(const std::vector<PhotometricReading>& readings,
                                         const PhotometricOptions& options, double theta_all) {
  if (options.model != PhotometricOptions::Model::Linear ||
      (options.loss != RobustLoss::None && options.loss != RobustLoss::Huber))
    return {};
  const size_t n = readings.size();
  const double clip = options.loss == RobustLoss::Huber ? options.loss_scale : std::numeric_limits<double>::infinity();
  std::vector<double> c(n), sorted(n), prefix(n + 1, 0.0);
  for (size_t i = 0; i < n; ++i) c[i] = std::log(readings[i].camera_value) - std::log(readings[i].measured);
  sorted = c;
  std::sort(sorted.begin(), sorted.end());
  for (size_t i = 0; i < n; ++i) prefix[i + 1] = prefix[i] + sorted[i];
  // The linear piece at theta without reading `skip`: theta + c clipped below for c < -clip -
  // theta, above for c > clip - theta; returns the root of that piece's line (or NaN).
  auto piece_root = [&](double theta, size_t skip) {
    const size_t lo = size_t(std::lower_bound(sorted.begin(), sorted.end(), -clip - theta) - sorted.begin());
    const size_t hi_start = size_t(std::upper_bound(sorted.begin(), sorted.end(), clip - theta) - sorted.begin());
    double below = double(lo), above = double(n - hi_start), inside = double(hi_start - lo);
    double sum_inside = prefix[hi_start] - prefix[lo];
    const double ck = c[skip];
    if (ck < -clip - theta) below -= 1;
    else if (ck > clip - theta) above -= 1;
    else inside -= 1, sum_inside -= ck;
    if (inside <= 0) return std::numeric_limits<double>::quiet_NaN();
    const double clipped = below == above ? 0.0 : clip * (below - above);  // no loss: nothing clipped (inf * 0)
    return (clipped - sum_inside) / inside;  // clip * (above - below) + inside * theta + sum_inside = 0
  };
  std::vector<double> out(n);
  for (size_t i = 0; i < n; ++i) {
    double theta = theta_all;
    bool settled = false;
    for (int step = 0; step < 50 && !settled; ++step) {
      const double next = piece_root(theta, i);
      if (!std::isfinite(next)) break;
      settled = next == theta || piece_root(next, i) == next;
      theta = next;
    }
    if (!settled) return {};  // a flat or cycling case: leave it to Ceres
    out[i] = theta;
  }
  return out;
}

// Prediction of reading r in its own unit.
double predict(const Fit& fit, const PhotometricReading& r, bool log_model) {
  if (!log_model) return std::exp(fit.params[0]) * r.camera_value;
  // {a, b}: b read as the last one, which GCC's -Warray-bounds (it cannot tie the length of
  // params to log_model once solve() is inlined) accepts.
  return std::exp((r.camera_value - fit.params.front()) / fit.params.back());
}

void validate(const std::vector<PhotometricReading>& readings, const PhotometricOptions& options) {
  const bool log_model = options.model == PhotometricOptions::Model::LogSensor;
  std::map<std::string, std::string> seen;
  for (const auto& r : readings) {
    if (!std::isfinite(r.camera_value))
      throw InputError(where(r) + ": camera value of '" + r.label + "' is " +
                       (r.region ? "unresolved (the image region was not read)" : "not finite"));
    if (!(r.camera_value > 0) && !log_model)
      throw InputError(where(r) + ": camera value " + std::to_string(r.camera_value) + " of '" + r.label + "' is not positive");
    if (!std::isfinite(r.measured) || !(r.measured > 0))
      throw InputError(where(r) + ": measured value " + std::to_string(r.measured) + " of '" + r.label + "' is not a positive number");
    if (!log_model && r.code_bits > 0)
      throw InputError(where(r) + ": '" + r.label + "' is a region of " + std::to_string(r.code_bits) +
                       "-bit camera codes, not relative radiance (not linearised, not divided by the exposure time); a "
                       "linear scale is read off the map it scales: give the region in the fused .exr (hdr fuse), or "
                       "fit a log sensor's codes (--model log)");
    // A region's camera value is its mean luminance: a lux reading is compared with E_rel, the
    // cosine-weighted integral over the upper hemisphere, and against a mean it gave a k
    // about pi times too large.
    if (r.region && r.unit == PhotometricReading::Unit::Lux)
      throw InputError(where(r) + ": '" + r.label + "' is an image region, whose value is a mean luminance; give its "
                       "reading in cd/m2 (a luminance meter), or a lux reading with the map's E_rel as camera_value");
    if (log_model && r.unit == PhotometricReading::Unit::Lux)
      throw InputError(where(r) + ": a log-sensor fit takes luminance (cd/m2) readings only, '" + r.label + "' is in lux");
    auto [it, inserted] = seen.emplace(r.label, where(r));
    if (!inserted) throw InputError(where(r) + ": duplicate label '" + r.label + "' (first at " + it->second + ")");
  }
  const size_t needed = log_model ? 3 : 2;
  if (readings.size() < needed) {
    const std::string file = readings.empty() || readings[0].source.empty()
                                 ? std::string("photometric readings")
                                 : readings[0].source.substr(0, readings[0].source.rfind(':'));
    throw InputError(file + ": " + std::to_string(readings.size()) + " reading(s); a " +
                     (log_model ? "log-sensor fit needs at least 3 (2 parameters" : "scale fit needs at least 2 (1 parameter") +
                     " plus one for the uncertainty and the held-out check)");
  }
}

}  // namespace

std::vector<PhotometricReading> read_readings_csv(const std::string& path) {
  std::istringstream in(read_text_file(path, "the readings file"));
  std::vector<PhotometricReading> readings;
  std::map<std::string, int> first_line;
  bool header = false;
  int line_no = 0;
  for (std::string line; std::getline(in, line);) {
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line_no == 1 && line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // UTF-8 BOM
    const std::string t = trim_blanks(line);
    if (t.empty() || t[0] == '#') continue;
    const std::string at = path + ":" + std::to_string(line_no);
    auto fields = split_csv(line, at);
    if (!header) {
      std::string h;
      for (size_t i = 0; i < fields.size(); ++i) h += (i ? "," : "") + lower(trim_blanks(fields[i]));
      if (h != "region,camera_value,measured,unit")
        throw InputError(at + ": header must be 'region,camera_value,measured,unit', found '" + t + "'");
      header = true;
      continue;
    }
    if (fields.size() != 4)
      throw InputError(at + ": expected 4 fields (region,camera_value,measured,unit), found " +
                       std::to_string(fields.size()) + (fields.size() > 4 ? " (quote a region that has commas)" : ""));
    PhotometricReading r;
    r.source = at;
    r.label = fields[0];
    if (r.label.empty()) throw InputError(at + ": empty region label");
    r.region = parse_region(r.label, at);
    if (trim_blanks(fields[1]).empty()) {
      if (!r.region) throw InputError(at + ": camera_value is empty and '" + r.label + "' is not an image region");
      r.camera_value = kNaN;
    } else {
      r.camera_value = parse_number(fields[1], "camera_value", at);
    }
    r.measured = parse_number(fields[2], "measured value", at);
    const auto unit = parse_unit(fields[3]);
    if (!unit) throw InputError(at + ": unknown unit '" + trim_blanks(fields[3]) + "' (cd/m2 or lux)");
    r.unit = *unit;
    auto [it, inserted] = first_line.emplace(r.label, line_no);
    if (!inserted)
      throw InputError(at + ": duplicate label '" + r.label + "' (first on line " + std::to_string(it->second) + ")");
    readings.push_back(std::move(r));
  }
  if (!header) throw InputError(path + ": no header 'region,camera_value,measured,unit'");
  if (readings.size() < 2)
    throw InputError(path + ": " + std::to_string(readings.size()) +
                     " reading(s); at least 2 are needed (one fits the scale, another checks it)");
  return readings;
}

void resolve_regions(std::vector<PhotometricReading>& readings, const std::string& base_dir) {
  std::map<std::string, RgbImage> images;
  for (auto& r : readings) {
    if (!r.region || std::isfinite(r.camera_value)) continue;
    std::filesystem::path dir = base_dir;
    if (dir.empty() && !r.source.empty())
      dir = std::filesystem::path(r.source.substr(0, r.source.rfind(':'))).parent_path();
    const std::filesystem::path image_path = std::filesystem::path(r.region->image).is_absolute()
                                                 ? std::filesystem::path(r.region->image)
                                                 : dir / r.region->image;
    auto it = images.find(image_path.string());
    if (it == images.end()) {
      try {
        it = images.emplace(image_path.string(), read_rgb_image(image_path.string())).first;
      } catch (const InputError& e) {
        throw InputError(where(r) + ": " + e.what());
      }
    }
    const RgbImage& image = it->second;
    const ImageRegion& g = *r.region;
    // k maps relative values to cd/m2. Fitted on a map in radiance units already (fused with
    // --photometric, or an EXR whose whiteLuminance makes it absolute) it came out near 683,
    // and scaled the relative maps it was applied to by that, with exit 0.
    if (image.units == Units::Radiance)
      throw InputError(fmt::format("{}: {} is in radiance units already (calibrated): fit on the relative map, e.g. "
                                   "hdr fuse without --photometric",
                                   where(r), image_path.string()));
    try {
      r.camera_value = mean_luminance_in_region(image, g.x, g.y, g.width, g.height);
    } catch (const InputError& e) {
      throw InputError(where(r) + ": " + image_path.string() + ": " + e.what());
    }
    r.code_bits = image.code_bits;
    // A clipped pixel's code says only "at least" (or "at most"): the mean is biased by an
    // unknown amount, which no loss can flag when every reading of a patch clips alike.
    if (const size_t clipped = clipped_codes_in_region(image, g.x, g.y, g.width, g.height))
      throw InputError(fmt::format("{}: {}: {} of {} pixels of region {},{},{},{} are clipped ({}-bit codes at 0 or "
                                   "the top): their mean is not the patch's; pick a region or an exposure that does not clip",
                                   where(r), image_path.string(), clipped, size_t(g.width) * size_t(g.height), g.x, g.y,
                                   g.width, g.height, image.code_bits));
  }
}

size_t clipped_codes_in_region(const RgbImage& image, int x, int y, int width, int height) {
  if (image.code_bits <= 0) return 0;
  const float top = 1.0f - 0.5f / float((1 << image.code_bits) - 1);  // codes are in [0, 1]
  size_t clipped = 0;
  for (int v = std::max(y, 0); v < std::min(y + height, image.height); ++v)
    for (int u = std::max(x, 0); u < std::min(x + width, image.width); ++u) {
      const float* p = &image.rgb[3 * (size_t(v) * size_t(image.width) + size_t(u))];
      const bool top_hit = p[0] >= top || p[1] >= top || p[2] >= top;
      const bool black = p[0] <= 0 && p[1] <= 0 && p[2] <= 0;
      clipped += top_hit || black;
    }
  return clipped;
}

double mean_luminance_in_region(const RgbImage& image, int x, int y, int width, int height) {
  if (x < 0 || y < 0 || width <= 0 || height <= 0 || int64_t(x) + width > image.width ||
      int64_t(y) + height > image.height)
    throw InputError("region " + std::to_string(x) + "," + std::to_string(y) + "," + std::to_string(width) +
                     "," + std::to_string(height) + " is not inside the " + std::to_string(image.width) +
                     "x" + std::to_string(image.height) + " image");
  double sum = 0;
  size_t count = 0;
  for (int v = y; v < y + height; ++v)
    for (int u = x; u < x + width; ++u) {
      const size_t i = size_t(v) * size_t(image.width) + size_t(u);
      if (!image.valid.empty() && !image.valid[i]) continue;
      const float* p = &image.rgb[3 * i];
      sum += luminance(p[0], p[1], p[2]);
      ++count;
    }
  if (count == 0) throw InputError("region holds no valid pixel");
  return sum / double(count);
}

double relative_illuminance(const EnvMap& map, Vec3 normal) {
  const double len = std::sqrt(normal.x * normal.x + normal.y * normal.y + normal.z * normal.z);
  double e = 0;
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    if (!map.is_valid(i)) continue;
    const Vec3 d = pixel_direction(map, i);
    const double c = (d.x * normal.x + d.y * normal.y + d.z * normal.z) / len;
    if (c <= 0) continue;
    const float* p = map.pixel(i);
    e += luminance(p[0], p[1], p[2]) * c * pixel_solid_angle(map, i);
  }
  return e;
}

PhotometricCalibration fit_photometric(const std::vector<PhotometricReading>& readings,
                                       const PhotometricOptions& options) {
  if (!(options.loss_scale > 0) || !std::isfinite(options.loss_scale))
    throw InputError("photometric options: loss scale must be a positive number");
  validate(readings, options);
  const bool log_model = options.model == PhotometricOptions::Model::LogSensor;
  const size_t n = readings.size();
  std::vector<size_t> all(n);
  for (size_t i = 0; i < n; ++i) all[i] = i;
  const Fit fit = solve(readings, all, options, true);

  PhotometricCalibration cal;
  cal.readings = int(n);
  cal.loss = loss_name(options.loss);
  cal.loss_scale = options.loss_scale;
  if (!log_model) {
    cal.scale_luminance = std::exp(fit.params[0]);
    cal.scale_relative_error = fit.sigma[0];  // sigma of ln k = relative sigma of k
  } else {
    cal.scale_luminance = 1.0;
    cal.log_sensor = LogSensorCurve{fit.params[0], fit.params[1], fit.sigma[0], fit.sigma[1]};
  }
  for (double& s : cal.scale_rgb) s = cal.scale_luminance / kLuminousEfficacy;

  const std::vector<double> held_fast = held_out_linear_fast(readings, options, fit.params[0]);
  double sum2 = 0, held2 = 0;
  for (size_t i = 0; i < n; ++i) {
    PhotometricResidual res;
    res.label = readings[i].label;
    res.measured = readings[i].measured;
    res.predicted = predict(fit, readings[i], log_model);
    res.relative = res.predicted / res.measured - 1;
    if (!held_fast.empty()) {
      res.held_out_relative = predict(Fit{{held_fast[i]}, {}}, readings[i], log_model) / res.measured - 1;
    } else {
      std::vector<size_t> rest;
      for (size_t j = 0; j < n; ++j)
        if (j != i) rest.push_back(j);
      const Fit held = solve(readings, rest, options, false);
      res.held_out_relative = predict(held, readings[i], log_model) / res.measured - 1;
    }
    sum2 += res.relative * res.relative;
    held2 += res.held_out_relative * res.held_out_relative;
    cal.max_abs_relative = std::max(cal.max_abs_relative, std::abs(res.relative));
    cal.residuals.push_back(std::move(res));
  }
  cal.rms_relative = std::sqrt(sum2 / double(n));
  cal.held_out_rms_relative = std::sqrt(held2 / double(n));
  return cal;
}

void save_photometric(const std::string& path, const PhotometricCalibration& c) {
  nlohmann::json j;
  j["format"] = "lightprobe.photometric/1";
  j["scale_luminance"] = c.scale_luminance;
  j["scale_luminance_note"] = "cd m^-2 per relative luminance unit";
  j["scale_rgb"] = c.scale_rgb;
  j["luminous_efficacy"] = kLuminousEfficacy;
  j["scale_relative_error"] = c.scale_relative_error;
  if (c.log_sensor)
    j["log_sensor"] = {{"a", c.log_sensor->a}, {"b", c.log_sensor->b},
                       {"sigma_a", c.log_sensor->sigma_a}, {"sigma_b", c.log_sensor->sigma_b}};
  else
    j["log_sensor"] = nullptr;
  j["readings"] = c.readings;
  j["loss"] = c.loss;
  j["loss_scale"] = c.loss_scale;
  j["rms_relative"] = c.rms_relative;
  j["max_abs_relative"] = c.max_abs_relative;
  j["held_out_rms_relative"] = c.held_out_rms_relative;
  nlohmann::json residuals = nlohmann::json::array();
  for (const auto& r : c.residuals)
    residuals.push_back({{"label", r.label}, {"predicted", r.predicted}, {"measured", r.measured},
                         {"relative", r.relative}, {"held_out_relative", r.held_out_relative}});
  j["residuals"] = residuals;
  write_file_atomically(path, j.dump(2) + "\n");
}

PhotometricCalibration load_photometric(const std::string& path) {
  const nlohmann::json j = read_json_file(path);
  check_json_format(j, path, "lightprobe.photometric/1");
  PhotometricCalibration c;
  try {
    c.scale_luminance = j.at("scale_luminance").get<double>();
    c.scale_rgb = j.at("scale_rgb").get<std::array<double, 3>>();
    c.scale_relative_error = j.value("scale_relative_error", 0.0);
    if (j.contains("log_sensor") && !j["log_sensor"].is_null()) {
      const auto& l = j["log_sensor"];
      c.log_sensor = LogSensorCurve{l.at("a").get<double>(), l.at("b").get<double>(),
                                    l.value("sigma_a", 0.0), l.value("sigma_b", 0.0)};
    }
    c.readings = j.value("readings", 0);
    c.loss = j.value("loss", "");
    c.loss_scale = j.value("loss_scale", 0.0);
    c.rms_relative = j.value("rms_relative", 0.0);
    c.max_abs_relative = j.value("max_abs_relative", 0.0);
    c.held_out_rms_relative = j.value("held_out_rms_relative", 0.0);
    if (j.contains("residuals"))
      for (const auto& r : j["residuals"])
        c.residuals.push_back({r.value("label", ""), r.value("predicted", 0.0), r.value("measured", 0.0),
                               r.value("relative", 0.0), r.value("held_out_relative", 0.0)});
  } catch (const nlohmann::json::exception& e) {
    throw InputError(json_field_problem(path, e));
  }
  for (double s : c.scale_rgb)
    if (!(s > 0) || !std::isfinite(s)) throw InputError(path + ": scale_rgb must hold three positive numbers");
  if (!(c.scale_luminance > 0) || !std::isfinite(c.scale_luminance))
    throw InputError(path + ": scale_luminance must be a positive number");
  return c;
}

namespace {
void scale_pixels(std::vector<float>& rgb, const PhotometricCalibration& c) {
  // A log sensor's codes are not proportional to radiance: scaling them would be a silent
  // wrong answer. They are decoded (hdr/log_sensor.h), which applies the scale itself.
  if (c.log_sensor)
    throw InputError("apply_photometric: a log-sensor calibration decodes raw codes (decode_log_sensor); it is not a linear scale");
  for (size_t i = 0; i + 2 < rgb.size(); i += 3)
    for (int k = 0; k < 3; ++k) rgb[i + k] = float(rgb[i + k] * c.scale_rgb[k]);
}
}  // namespace

void apply_photometric(RgbImage& image, const PhotometricCalibration& c) {
  if (image.units == Units::Radiance)
    throw InputError("apply_photometric: the image is already in radiance units (the scale would apply twice)");
  scale_pixels(image.rgb, c);
  image.units = Units::Radiance;
}

void apply_photometric(EnvMap& map, const PhotometricCalibration& c) {
  if (map.units == Units::Radiance)
    throw InputError("apply_photometric: the map is already in radiance units (the scale would apply twice)");
  scale_pixels(map.rgb, c);
  map.units = Units::Radiance;
}

}  // namespace lp
