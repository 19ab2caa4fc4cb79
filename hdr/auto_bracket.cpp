#include "hdr/auto_bracket.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "core/error.h"

namespace lp {
namespace {

void check_code(double code, const char* name) {
  if (!(code > 0 && code < 1)) throw InputError(fmt::format("auto bracket: {} {} is not inside (0, 1)", name, code));
}

void check_options(const AutoBracketOptions& o, const ExposureLimits& l, double headroom) {
  if (!(o.dark_fraction >= 0 && o.dark_fraction < 1)) throw InputError("auto bracket: dark fraction must be in [0, 1)");
  if (!(o.overlap >= 1)) throw InputError("auto bracket: overlap must be >= 1");
  if (!(headroom >= 1)) throw InputError("auto bracket: headroom must be >= 1");
  if (!(o.replan_margin > 1 && o.replan_margin < o.headroom))
    throw InputError("auto bracket: the re-plan margin must be above 1 and below the headroom");
  if (!(o.probe_factor >= 1)) throw InputError("auto bracket: probe factor must be >= 1");
  if (!(l.min_seconds > 0) || !(l.max_seconds >= l.min_seconds) || !std::isfinite(l.max_seconds))
    throw InputError(fmt::format("auto bracket: exposure limits {:g}..{:g} s are not 0 < min <= max", l.min_seconds,
                                 l.max_seconds));
  if (l.max_exposures < 1 || l.min_exposures < 1 || l.min_exposures > l.max_exposures)
    throw InputError(fmt::format("auto bracket: exposure counts {}..{} are not 1 <= min <= max", l.min_exposures,
                                 l.max_exposures));
}

bool same_times(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (std::abs(a[i] / b[i] - 1) > 0.01) return false;
  return true;
}

// cover_low/high, covered_fraction and reason of a plan's times over a metered scene.
void describe_coverage(BracketPlan& plan, const MeteredScene& scene, const ExposureWindow& window,
                       const AutoBracketOptions& options) {
  const std::vector<double>& times = plan.exposure_seconds;
  plan.cover_low = window.x_low / times.back();
  plan.cover_high = window.x_high / times.front();
  double t_meter_short = 0, t_meter_long = 0;
  if (!scene.exposure_seconds.empty()) {
    t_meter_short = *std::min_element(scene.exposure_seconds.begin(), scene.exposure_seconds.end());
    t_meter_long = *std::max_element(scene.exposure_seconds.begin(), scene.exposure_seconds.end());
  }
  size_t covered = 0;
  for (float v : scene.radiance) {
    // A pixel clipped (black) when metered counts as covered only if its assumed value is.
    double lo = v, hi = v;
    if (t_meter_short > 0 && v * t_meter_short >= window.x_clipped) hi = v * options.probe_factor;
    if (t_meter_long > 0 && v * t_meter_long <= window.x_black) lo = v / options.probe_factor;
    covered += lo >= plan.cover_low && hi <= plan.cover_high;
  }
  plan.covered_fraction = double(covered) / double(scene.radiance.size());
  plan.reason = fmt::format("scene {:.1f} stops ({:.3g}{} .. {:.3g}{}); {} exposure{} {:.3g} .. {:.3g} s cover "
                            "{:.3g} .. {:.3g}, {:.1f} % of the pixels{}",
                            plan.scene_stops, plan.scene_low, plan.dark_black_in_meter ? " guessed, black" : "",
                            plan.scene_high, plan.bright_clipped_in_meter ? " guessed, clipped" : "", times.size(),
                            times.size() == 1 ? "" : "s", times.front(), times.back(), plan.cover_low, plan.cover_high,
                            100 * plan.covered_fraction, plan.limit_text);
}

}  // namespace

const char* to_string(BracketLimit limit) {
  switch (limit) {
    case BracketLimit::None: return "none";
    case BracketLimit::BrightShortest: return "bright end clipped: shortest exposure";
    case BracketLimit::DarkLongest: return "dark end under the floor: longest exposure";
    case BracketLimit::DarkMaxExposures: return "dark end under the floor: exposure count";
  }
  return "none";
}

ExposureWindow usable_exposure_window(const CameraResponse& response, const CoverageCodes& codes) {
  check_response(response, "auto bracket response");
  check_code(codes.min_code, "min code");
  check_code(codes.max_code, "max code");
  check_code(codes.clipped_code, "clipped code");
  check_code(codes.black_code, "black code");
  if (!(codes.min_code < codes.max_code)) throw InputError("auto bracket: min code must be below max code");
  // The narrowest window over the channels: every channel must be usable there.
  auto x_at = [&](double code, bool largest) {
    const size_t level = size_t(std::lround(code * double(response.levels - 1)));
    double x = largest ? 0 : INFINITY;
    for (const auto& g : response.log_exposure) {
      const double v = std::exp(double(g[level]));
      x = largest ? std::max(x, v) : std::min(x, v);
    }
    return x;
  };
  ExposureWindow w;
  w.min_code = codes.min_code;
  w.max_code = codes.max_code;
  w.x_low = x_at(codes.min_code, true);
  w.x_high = x_at(codes.max_code, false);
  w.x_clipped = x_at(codes.clipped_code, false);  // flags more pixels clipped rather than fewer
  w.x_black = x_at(codes.black_code, true);
  if (!(w.x_high > w.x_low))
    throw InputError("auto bracket: the response maps the usable codes to no exposure range (not increasing)");
  return w;
}

MeteredScene meter_image(const RgbImage& radiance, std::vector<double> exposure_seconds) {
  MeteredScene scene;
  scene.exposure_seconds = std::move(exposure_seconds);
  const size_t pixels = size_t(radiance.width) * size_t(radiance.height);
  scene.radiance.reserve(pixels);
  for (size_t i = 0; i < pixels && 3 * i + 2 < radiance.rgb.size(); ++i) {
    if (!radiance.valid.empty() && !radiance.valid[i]) continue;
    const float v = std::max({radiance.rgb[3 * i], radiance.rgb[3 * i + 1], radiance.rgb[3 * i + 2]});
    if (std::isfinite(v) && v > 0) scene.radiance.push_back(v);
  }
  return scene;
}

MeteredScene meter_unfusable_bracket(const std::vector<RgbImage>& frames, const std::vector<double>& exposure_seconds,
                                     const CameraResponse& response, const ExposureWindow& window) {
  if (frames.empty() || frames.size() != exposure_seconds.size())
    throw InputError("auto bracket: a bracket to meter needs one exposure time per frame");
  check_response(response, "auto bracket response");
  const auto [shortest, longest] = std::minmax_element(exposure_seconds.begin(), exposure_seconds.end());
  const RgbImage& short_frame = frames[size_t(shortest - exposure_seconds.begin())];
  const float brightest = short_frame.rgb.empty() ? 0.f : *std::max_element(short_frame.rgb.begin(), short_frame.rgb.end());
  const size_t brightest_level = size_t(std::lround(std::clamp(double(brightest), 0.0, 1.0) * (response.levels - 1)));
  const bool all_black = std::exp(double(response.log_exposure[1][brightest_level])) <= window.x_black;
  const size_t k = size_t((all_black ? longest : shortest) - exposure_seconds.begin());
  const RgbImage& codes = frames[k];
  RgbImage radiance = codes;
  for (size_t i = 0; i < radiance.rgb.size(); ++i) {
    const size_t level = size_t(std::lround(std::clamp(double(codes.rgb[i]), 0.0, 1.0) * (response.levels - 1)));
    radiance.rgb[i] = float(std::exp(double(response.log_exposure[i % 3][level])) / exposure_seconds[k]);
  }
  return meter_image(radiance, {exposure_seconds[k]});
}

BracketPlan plan_bracket(const MeteredScene& scene, const ExposureWindow& window, const ExposureLimits& limits,
                         const AutoBracketOptions& options, double headroom) {
  if (headroom < 0) headroom = options.headroom;
  check_options(options, limits, headroom);
  if (scene.radiance.empty()) throw InputError("auto bracket: the metered scene has no pixel with radiance > 0");
  const double step = window.x_high / window.x_low / options.overlap;  // largest ratio between neighbours
  if (!(step > 1)) throw InputError("auto bracket: the usable window is narrower than the overlap");

  BracketPlan plan;
  std::vector<float> sorted = scene.radiance;
  const size_t n_pix = sorted.size();
  const size_t dark_index = size_t(std::floor(options.dark_fraction * double(n_pix - 1)));
  std::nth_element(sorted.begin(), sorted.begin() + dark_index, sorted.end());
  double low = sorted[dark_index];
  double high = *std::max_element(sorted.begin(), sorted.end());
  // Ends the metering bracket could not see are a bound, not a value: look further out.
  double t_meter_short = 0, t_meter_long = 0;
  if (!scene.exposure_seconds.empty()) {
    t_meter_short = *std::min_element(scene.exposure_seconds.begin(), scene.exposure_seconds.end());
    t_meter_long = *std::max_element(scene.exposure_seconds.begin(), scene.exposure_seconds.end());
    plan.bright_clipped_in_meter = high * t_meter_short >= window.x_clipped;
    plan.dark_black_in_meter = low * t_meter_long <= window.x_black;
    if (plan.bright_clipped_in_meter) high *= options.probe_factor;
    if (plan.dark_black_in_meter) low /= options.probe_factor;
  }
  plan.scene_low = low;
  plan.scene_high = std::max(high, low);
  plan.scene_stops = std::log2(plan.scene_high / plan.scene_low);

  // The shortest time puts the brightest pixel (with headroom) at max_code, the longest the
  // darkest at min_code.
  const double need_short = window.x_high / (plan.scene_high * headroom);
  const double need_long = window.x_low * headroom / plan.scene_low;
  double t_short = std::clamp(need_short, limits.min_seconds, limits.max_seconds);
  double t_long = std::clamp(need_long, limits.min_seconds, limits.max_seconds);
  std::string limited;
  if (need_short < limits.min_seconds) {
    plan.limit = BracketLimit::BrightShortest;
    limited += fmt::format("; bright end clipped: {:g} s is the shortest exposure", limits.min_seconds);
  }
  int n = t_long <= t_short ? 1 : 1 + int(std::ceil(std::log(t_long / t_short) / std::log(step) - 1e-9));
  if (n > limits.max_exposures) {
    // Not enough frames: keep the bright end (the lights), give up the dark one.
    n = limits.max_exposures;
    t_long = std::min(t_short * std::pow(step, n - 1), limits.max_seconds);
    if (plan.limit == BracketLimit::None) plan.limit = BracketLimit::DarkMaxExposures;
    limited += fmt::format("; dark end under the floor: {} exposures at most", limits.max_exposures);
  } else if (need_long > limits.max_seconds) {
    if (plan.limit == BracketLimit::None) plan.limit = BracketLimit::DarkLongest;
    limited += fmt::format("; dark end under the floor: {:g} s is the longest exposure", limits.max_seconds);
  }
  std::vector<double>& times = plan.exposure_seconds;
  if (n < limits.min_exposures) {
    // More frames than the scene needs: spread them as far as they stay contiguous, around
    // the middle of what is needed, for headroom at no extra cost.
    n = limits.min_exposures;
    const double centre = std::sqrt(t_short * std::max(t_long, t_short));
    for (int i = 0; i < n; ++i) times.push_back(centre * std::pow(step, double(i) - 0.5 * (n - 1)));
    const double shift = times.front() < limits.min_seconds   ? limits.min_seconds / times.front()
                         : times.back() > limits.max_seconds ? limits.max_seconds / times.back()
                                                             : 1.0;
    for (double& t : times) t = std::clamp(t * shift, limits.min_seconds, limits.max_seconds);
  } else if (n == 1) {
    times.push_back(std::sqrt(t_short * t_long));  // anywhere in [t_long, t_short] covers: the middle
  } else {
    const double ratio = std::pow(t_long / t_short, 1.0 / (n - 1));
    for (int i = 0; i < n; ++i) times.push_back(t_short * std::pow(ratio, i));
  }
  // Limits narrower than the plan can make times equal; a bracket needs distinct ones.
  times.erase(std::unique(times.begin(), times.end(), [](double a, double b) { return b <= a * 1.000001; }),
              times.end());

  plan.limit_text = limited;
  describe_coverage(plan, scene, window, options);
  return plan;
}

AutoBracketPlanner::AutoBracketPlanner(ExposureWindow window, ExposureLimits limits, AutoBracketOptions options)
    : window_(window), limits_(limits), options_(options) {
  check_options(options_, limits_, options_.headroom);
}

bool AutoBracketPlanner::update(const MeteredScene& scene) {
  BracketPlan candidate = plan_bracket(scene, window_, limits_, options_);
  if (!has_plan()) {
    plan_ = std::move(candidate);
    decision_ = "first plan";
    return true;
  }
  const double m = options_.replan_margin;
  auto adopt = [&](BracketPlan p, std::string why) {
    const bool changed = !same_times(p.exposure_seconds, plan_.exposure_seconds);
    decision_ = changed ? std::move(why) : "steady (" + why + ", but no better plan)";
    plan_ = std::move(p);  // the same times: keep the fresher description
    changes_ += changed;
    return changed;
  };
  // Growing or shifting: an end of the scene near or past what the bracket covers, and a
  // plan that does better at that end (at a camera limit, nothing does: no re-plan).
  const bool bright = candidate.scene_high * m > plan_.cover_high && candidate.cover_high > plan_.cover_high * 1.01;
  const bool dark = candidate.scene_low < plan_.cover_low * m && candidate.cover_low < plan_.cover_low / 1.01;
  if (bright || dark)
    return adopt(std::move(candidate), fmt::format("{} end within {:g}x of the bracket's edge", bright ? "bright" : "dark", m));
  // Shrinking: only when fewer frames would still leave headroom * margin.
  BracketPlan wide = plan_bracket(scene, window_, limits_, options_, options_.headroom * m);
  const size_t fewer = wide.exposure_seconds.size();
  if (fewer < plan_.exposure_seconds.size())
    return adopt(std::move(wide), fmt::format("range shrank: {} exposures suffice", fewer));
  decision_ = "steady";
  // Keep the plan's times; say what they cover of the scene as metered now.
  candidate.exposure_seconds = plan_.exposure_seconds;
  // The camera's limits as they bear on the scene now: an end the kept times miss where
  // they are at a limit (when the plan was made, that end may have been a guess).
  const std::vector<double>& t = candidate.exposure_seconds;
  const bool bright_missed = candidate.scene_high > window_.x_high / t.front();
  const bool dark_missed = candidate.scene_low < window_.x_low / t.back();
  candidate.limit = BracketLimit::None;
  candidate.limit_text.clear();
  if (bright_missed && t.front() <= limits_.min_seconds * 1.000001) {
    candidate.limit = BracketLimit::BrightShortest;
    candidate.limit_text = fmt::format("; bright end clipped: {:g} s is the shortest exposure", limits_.min_seconds);
  }
  if (dark_missed && (t.back() >= limits_.max_seconds / 1.000001 || int(t.size()) >= limits_.max_exposures)) {
    const bool longest = t.back() >= limits_.max_seconds / 1.000001;
    if (candidate.limit == BracketLimit::None)
      candidate.limit = longest ? BracketLimit::DarkLongest : BracketLimit::DarkMaxExposures;
    candidate.limit_text += longest ? fmt::format("; dark end under the floor: {:g} s is the longest exposure", limits_.max_seconds)
                                    : fmt::format("; dark end under the floor: {} exposures at most", limits_.max_exposures);
  }
  describe_coverage(candidate, scene, window_, options_);
  plan_ = std::move(candidate);
  return false;
}

}  // namespace lp
