#include "calib/vignetting.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "core/error.h"
#include "core/json_file.h"

namespace lp {

namespace {

constexpr int kMaxTerms = VignettingModel::kMaxTerms;

double polynomial(const std::array<double, kMaxTerms>& k, double r2) {
  double v = 0;
  for (int m = kMaxTerms - 1; m >= 0; --m) v = (v + k[size_t(m)]) * r2;
  return 1 + v;
}
// dV / d(r^2)
double polynomial_slope(const std::array<double, kMaxTerms>& k, double r2) {
  double s = 0;
  for (int m = kMaxTerms; m >= 1; --m) s = s * r2 + m * k[size_t(m - 1)];
  return s;
}

// One block mean of one flat, at its pixel position, over the flat's bright level.
struct Block {
  double x = 0, y = 0, value = 0;
  int flat = 0;
  int bx = 0, by = 0;  // place in the flat's grid of blocks
};

int block_size(int width, int height) { return std::max(2, int(std::lround(std::min(width, height) / 64.0))); }

// The measurable blocks of every flat (VignettingFitOptions::dark_fraction says which).
std::vector<Block> flat_blocks(const std::vector<FlatField>& flats, double dark_fraction) {
  std::vector<Block> all;
  for (size_t f = 0; f < flats.size(); ++f) {
    const FlatField& flat = flats[f];
    const int b = block_size(flat.width, flat.height);
    const int bw = flat.width / b, bh = flat.height / b;
    std::vector<Block> blocks;
    for (int by = 0; by < bh; ++by)
      for (int bx = 0; bx < bw; ++bx) {
        double sum = 0, lowest = std::numeric_limits<double>::infinity();
        bool usable = true;
        for (int y = by * b; y < (by + 1) * b && usable; ++y)
          for (int x = bx * b; x < (bx + 1) * b; ++x) {
            const float v = flat.luminance[size_t(y) * size_t(flat.width) + size_t(x)];
            if (!std::isfinite(v)) {
              usable = false;
              break;
            }
            sum += v;
            lowest = std::min(lowest, double(v));
          }
        const double mean = sum / double(b * b);
        // A block across the edge of the image circle (or a speck) is not a level.
        if (!usable || !(mean > 0) || lowest < mean / 3) continue;
        blocks.push_back({bx * b + (b - 1) / 2.0, by * b + (b - 1) / 2.0, mean, int(f), bx, by});
      }
    if (blocks.empty()) continue;
    std::vector<double> means;
    for (const Block& bl : blocks) means.push_back(bl.value);
    const size_t q = std::min(means.size() - 1, size_t(0.99 * double(means.size())));
    std::nth_element(means.begin(), means.begin() + long(q), means.end());
    const double bright = means[q];
    for (Block& bl : blocks)
      if (bl.value >= dark_fraction * bright) {
        bl.value /= bright;
        all.push_back(bl);
      }
  }
  return all;
}

struct FitState {
  std::array<double, 2> centre{0, 0};
  std::array<double, kMaxTerms> k{};
  std::vector<double> log_scale;  // per flat
};

// Residuals e = value / (s V) - 1 and their Jacobian in the parameters
// [cx, cy (when free), k1..k_terms, ln s_1..ln s_F].
struct Problem {
  const std::vector<Block>* blocks = nullptr;
  const std::vector<char>* kept = nullptr;
  double radius_px = 1;
  int terms = 3;
  bool free_centre = true;
  int flats = 1;

  int parameters() const { return (free_centre ? 2 : 0) + terms + flats; }

  // Cost and (optionally) the normal equations.
  double evaluate(const FitState& s, Eigen::MatrixXd* jtj, Eigen::VectorXd* jte) const {
    const int p = parameters();
    if (jtj) {
      jtj->setZero(p, p);
      jte->setZero(p);
    }
    Eigen::VectorXd row(p);
    double cost = 0;
    const double inv_r2 = 1.0 / (radius_px * radius_px);
    for (size_t j = 0; j < blocks->size(); ++j) {
      if (!(*kept)[j]) continue;
      const Block& b = (*blocks)[j];
      const double dx = b.x - s.centre[0], dy = b.y - s.centre[1];
      const double r2 = (dx * dx + dy * dy) * inv_r2;
      const double v = polynomial(s.k, r2);
      const double scale = std::exp(s.log_scale[size_t(b.flat)]);
      // A trial step that bends V through zero is rejected by its cost.
      if (!(v > 1e-6)) return std::numeric_limits<double>::infinity();
      const double ratio = b.value / (scale * v);
      const double e = ratio - 1;
      cost += e * e;
      if (!jtj) continue;
      row.setZero();
      int c = 0;
      const double de_dv = -ratio / v;
      if (free_centre) {
        const double dv_dr2 = polynomial_slope(s.k, r2);
        row[c++] = de_dv * dv_dr2 * (-2 * dx * inv_r2);
        row[c++] = de_dv * dv_dr2 * (-2 * dy * inv_r2);
      }
      double power = r2;
      for (int m = 0; m < terms; ++m, power *= r2) row[c++] = de_dv * power;
      row[c + b.flat] = -ratio;
      jtj->selfadjointView<Eigen::Lower>().rankUpdate(row);
      *jte += row * e;
    }
    if (jtj) *jtj = jtj->selfadjointView<Eigen::Lower>();
    return cost;
  }

  void step(FitState& s, const Eigen::VectorXd& d) const {
    int c = 0;
    if (free_centre) {
      s.centre[0] += d[c++];
      s.centre[1] += d[c++];
    }
    for (int m = 0; m < terms; ++m) s.k[size_t(m)] += d[c++];
    for (int f = 0; f < flats; ++f) s.log_scale[size_t(f)] += d[c++];
  }
};

// Levenberg-Marquardt on the problem's normal equations, with Eigen: 3-7 parameters plus one
// scale per flat, over a few thousand blocks, with an analytic Jacobian. The Ceres plugin
// (calib/ceres_plugin.h: 17 libraries loaded on first use) is not needed for a problem this
// small; the whole fit of two 800x600 flats, reading included, takes about 50 ms. Returns the cost.
double solve(const Problem& problem, FitState& state, Eigen::MatrixXd* covariance_jtj = nullptr) {
  Eigen::MatrixXd jtj;
  Eigen::VectorXd jte;
  double cost = problem.evaluate(state, &jtj, &jte);
  double lambda = 1e-3;
  for (int iteration = 0; iteration < 100; ++iteration) {
    Eigen::MatrixXd a = jtj;
    for (int i = 0; i < a.rows(); ++i) a(i, i) += lambda * std::max(a(i, i), 1e-12);
    const Eigen::VectorXd d = a.ldlt().solve(-jte);
    if (!d.allFinite()) break;
    FitState trial = state;
    problem.step(trial, d);
    const double trial_cost = problem.evaluate(trial, nullptr, nullptr);
    if (trial_cost < cost) {
      const bool converged = cost - trial_cost < 1e-12 * std::max(cost, 1e-30) || d.norm() < 1e-10;
      state = trial;
      cost = problem.evaluate(state, &jtj, &jte);
      lambda = std::max(lambda / 4, 1e-9);
      if (converged) break;
    } else {
      lambda *= 8;
      if (lambda > 1e12) break;
    }
  }
  if (covariance_jtj) *covariance_jtj = jtj;
  return cost;
}

size_t count_kept(const std::vector<char>& kept) { return size_t(std::count(kept.begin(), kept.end(), 1)); }

// Blocks that differ from their neighbourhood (the 5 x 5 blocks around them in their flat) by
// more than the threshold, in their residual from the fit: dust and specks are local; where the
// model misfits a lens the residual changes slowly, and those blocks are kept.
size_t drop_outliers(const Problem& problem, const FitState& s, std::vector<char>& kept, double sigmas) {
  const std::vector<Block>& blocks = *problem.blocks;
  int width = 0, height = 0, flats = 0;
  for (const Block& b : blocks) {
    width = std::max(width, b.bx + 1);
    height = std::max(height, b.by + 1);
    flats = std::max(flats, b.flat + 1);
  }
  const size_t plane = size_t(width) * size_t(height);
  std::vector<double> grid(plane * size_t(flats), std::numeric_limits<double>::quiet_NaN());
  auto at = [&](int f, int x, int y) -> double& { return grid[size_t(f) * plane + size_t(y) * size_t(width) + size_t(x)]; };
  for (size_t j = 0; j < blocks.size(); ++j) {
    if (!kept[j]) continue;
    const Block& b = blocks[j];
    const double dx = b.x - s.centre[0], dy = b.y - s.centre[1];
    const double v = polynomial(s.k, (dx * dx + dy * dy) / (problem.radius_px * problem.radius_px));
    at(b.flat, b.bx, b.by) = b.value / (std::exp(s.log_scale[size_t(b.flat)]) * v) - 1;
  }
  std::vector<double> local(blocks.size(), 0), abs_local, around;
  for (size_t j = 0; j < blocks.size(); ++j) {
    if (!kept[j]) continue;
    const Block& b = blocks[j];
    around.clear();
    for (int y = std::max(0, b.by - 2); y <= std::min(height - 1, b.by + 2); ++y)
      for (int x = std::max(0, b.bx - 2); x <= std::min(width - 1, b.bx + 2); ++x)
        if ((x != b.bx || y != b.by) && std::isfinite(at(b.flat, x, y))) around.push_back(at(b.flat, x, y));
    if (around.size() < 3) continue;
    std::nth_element(around.begin(), around.begin() + long(around.size() / 2), around.end());
    local[j] = at(b.flat, b.bx, b.by) - around[around.size() / 2];
    abs_local.push_back(std::abs(local[j]));
  }
  if (abs_local.empty()) return 0;
  std::nth_element(abs_local.begin(), abs_local.begin() + long(abs_local.size() / 2), abs_local.end());
  const double threshold = std::max(sigmas * 1.4826 * abs_local[abs_local.size() / 2], 0.01);
  size_t dropped = 0;
  for (size_t j = 0; j < blocks.size(); ++j)
    if (kept[j] && std::abs(local[j]) > threshold) {
      kept[j] = 0;
      ++dropped;
    }
  return dropped;
}

// The first r in [0, max_radius] where V leaves (0.02, 1.5], or -1.
double implausible_radius(const std::array<double, kMaxTerms>& k, double max_radius) {
  for (int i = 0; i <= 400; ++i) {
    const double r = max_radius * i / 400.0;
    const double v = polynomial(k, r * r);
    if (!(v > 0.02 && v <= 1.5)) return r;
  }
  return -1;
}

double half_diagonal(int width, int height) { return 0.5 * std::hypot(double(width), double(height)); }

}  // namespace

double relative_illumination(const VignettingModel& m, double x, double y) {
  const double dx = x - m.centre[0], dy = y - m.centre[1];
  const double r = std::sqrt(dx * dx + dy * dy) / m.radius_px, edge = m.max_radius;
  if (r <= edge) return polynomial(m.k, r * r);
  // Beyond the measured radius: on along the edge's tangent (the image's corners lie half a
  // block beyond the last block's centre: holding V there was 3 % off on a cos^4 lens),
  // never below half the edge's V (far out, outside a fisheye's circle, nothing is measured).
  const double e2 = edge * edge;
  const double slope = 2 * edge * polynomial_slope(m.k, e2);
  const double v_edge = polynomial(m.k, e2);
  return std::max(v_edge + slope * (r - edge), 0.5 * v_edge);
}

VignettingModel fit_vignetting(const std::vector<FlatField>& flats, const VignettingFitOptions& options) {
  if (flats.empty()) throw InputError("vignetting: no flat field given");
  if (options.terms < 0 || options.terms > kMaxTerms)
    throw InputError(fmt::format("vignetting: terms must be 0 (automatic) to {}", kMaxTerms));
  const FlatField& first = flats.front();
  for (const FlatField& f : flats) {
    if (f.width < 16 || f.height < 16 || f.luminance.size() != size_t(f.width) * size_t(f.height))
      throw InputError(fmt::format("{}: a flat field must be at least 16x16 pixels", f.name));
    if (f.width != first.width || f.height != first.height)
      throw InputError(fmt::format("{}: {}x{}, but {} is {}x{}: flat fields of one camera have one size", f.name,
                                   f.width, f.height, first.name, first.width, first.height));
  }
  const std::vector<Block> blocks = flat_blocks(flats, options.dark_fraction);
  for (size_t f = 0; f < flats.size(); ++f)
    if (std::none_of(blocks.begin(), blocks.end(), [&](const Block& b) { return b.flat == int(f); }))
      throw InputError(fmt::format("{}: no block of the image can be measured (clipped, black or no data everywhere): "
                                   "expose a flat field so that its brightest part is below the top code",
                                   flats[f].name));
  constexpr size_t kMinBlocks = 64;
  if (blocks.size() < kMinBlocks)
    throw InputError(fmt::format("{}: only {} blocks of the flat fields can be measured, {} needed: most of the image "
                                 "is clipped or dark",
                                 first.name, blocks.size(), kMinBlocks));

  VignettingModel model;
  model.image_width = first.width;
  model.image_height = first.height;
  model.radius_px = half_diagonal(first.width, first.height);
  model.flats = int(flats.size());
  const std::array<double, 2> image_centre{(first.width - 1) / 2.0, (first.height - 1) / 2.0};

  std::vector<char> kept(blocks.size(), 1);
  Problem problem;
  problem.blocks = &blocks;
  problem.kept = &kept;
  problem.radius_px = model.radius_px;
  problem.flats = int(flats.size());

  // Each fit starts from V = 1 (always feasible) with the centre and scales of `start`: the
  // coefficients of a fit with more terms, truncated, can bend V through zero, where the cost
  // is infinite and no step improves on it.
  auto fit = [&](int terms, bool free_centre, FitState start) {
    problem.terms = terms;
    problem.free_centre = free_centre;
    start.k = {};
    solve(problem, start);
    return start;
  };
  FitState start;
  start.centre = image_centre;
  start.log_scale.assign(flats.size(), 0.0);

  // The centre is fitted where the falloff places it; a weak one cannot.
  auto centre_holds = [&](const FitState& s) {
    return std::isfinite(s.centre[0]) && std::isfinite(s.centre[1]) &&
           std::hypot(s.centre[0] - image_centre[0], s.centre[1] - image_centre[1]) <= 0.1 * model.radius_px;
  };
  bool free_centre = true;
  FitState full = fit(kMaxTerms, true, start);
  if (!centre_holds(full)) {
    free_centre = false;
    full = fit(kMaxTerms, false, start);
  }
  model.blocks_dropped = drop_outliers(problem, full, kept, options.outlier_sigmas);
  if (count_kept(kept) < kMinBlocks)
    throw InputError(fmt::format("{}: the flat fields do not follow one smooth falloff (most blocks are off any fit): "
                                 "is the light uniform?",
                                 first.name));

  // The fewest terms the blocks support (BIC), or the number asked for.
  FitState best;
  double best_score = std::numeric_limits<double>::infinity();
  const double n = double(count_kept(kept));
  for (int terms = 1; terms <= kMaxTerms; ++terms) {
    if (options.terms != 0 && terms != options.terms) continue;
    FitState s = fit(terms, free_centre, full);
    if (free_centre && !centre_holds(s)) continue;
    problem.terms = terms;
    const double cost = problem.evaluate(s, nullptr, nullptr);
    const double score = n * std::log(std::max(cost, 1e-300) / n) + problem.parameters() * std::log(n);
    if (score < best_score) {
      best_score = score;
      best = s;
      model.terms = terms;
    }
  }
  if (model.terms == 0) {  // every free-centre fit wandered: the image centre
    free_centre = false;
    const int terms = options.terms == 0 ? kMaxTerms : options.terms;
    best = fit(terms, false, full);
    model.terms = terms;
  }
  problem.terms = model.terms;
  problem.free_centre = free_centre;
  Eigen::MatrixXd jtj;
  const double cost = solve(problem, best, &jtj);
  model.centre = best.centre;
  model.centre_from = free_centre ? "fit" : "image";
  model.k = best.k;
  model.blocks = count_kept(kept);
  model.rms_relative = std::sqrt(cost / double(model.blocks));

  double max_r = 0;
  for (size_t j = 0; j < blocks.size(); ++j)
    if (kept[j])
      max_r = std::max(max_r, std::hypot(blocks[j].x - model.centre[0], blocks[j].y - model.centre[1]) / model.radius_px);
  model.max_radius = max_r;

  // Uncertainty of V at the measured edge, from the fit's covariance (the blocks' residuals
  // taken as independent: model misfit is not, so this is a lower bound).
  const int p = problem.parameters();
  const double dof = std::max(1.0, double(model.blocks) - p);
  const Eigen::MatrixXd covariance = (cost / dof) * jtj.ldlt().solve(Eigen::MatrixXd::Identity(p, p));
  Eigen::VectorXd g = Eigen::VectorXd::Zero(p);
  int c = free_centre ? 2 : 0;
  if (free_centre) g[0] = polynomial_slope(model.k, max_r * max_r) * (-2 * max_r / model.radius_px);  // along +x
  double power = max_r * max_r;
  for (int m = 0; m < model.terms; ++m, power *= max_r * max_r) g[c + m] = power;
  const double v_edge = polynomial(model.k, max_r * max_r);
  model.edge_sigma_relative = std::sqrt(std::max(0.0, double(g.dot(covariance * g)))) / v_edge;

  if (const double r = implausible_radius(model.k, max_r); r >= 0)
    throw InputError(fmt::format("{}: the fitted falloff is no lens's (V = {:.3g} at r = {:.2f} of the half-diagonal): "
                                 "are the flat fields evenly lit and unclipped?",
                                 first.name, polynomial(model.k, r * r), r));
  return model;
}

std::vector<VignettingSample> vignetting_samples(const std::vector<FlatField>& flats, const VignettingModel& model,
                                                 size_t max_points) {
  const std::vector<Block> blocks = flat_blocks(flats, VignettingFitOptions{}.dark_fraction);
  // Each flat's scale: the median of its blocks over the model.
  std::vector<std::vector<double>> ratios(flats.size());
  std::vector<double> v(blocks.size());
  for (size_t j = 0; j < blocks.size(); ++j) {
    v[j] = relative_illumination(model, blocks[j].x, blocks[j].y);
    ratios[size_t(blocks[j].flat)].push_back(blocks[j].value / v[j]);
  }
  std::vector<double> scale(flats.size(), 1.0);
  for (size_t f = 0; f < flats.size(); ++f)
    if (!ratios[f].empty()) {
      std::nth_element(ratios[f].begin(), ratios[f].begin() + long(ratios[f].size() / 2), ratios[f].end());
      scale[f] = ratios[f][ratios[f].size() / 2];
    }
  std::vector<VignettingSample> out;
  const size_t stride = std::max<size_t>(1, (blocks.size() + max_points - 1) / std::max<size_t>(1, max_points));
  for (size_t j = 0; j < blocks.size(); j += stride)
    out.push_back({std::hypot(blocks[j].x - model.centre[0], blocks[j].y - model.centre[1]) / model.radius_px,
                   blocks[j].value / scale[size_t(blocks[j].flat)]});
  return out;
}

VignettingModel vignetting_as_shown(const VignettingModel& stored, int orientation) {
  if (orientation == 1) return stored;
  VignettingModel shown = stored;
  shown.centre = shown_from_stored(orientation, stored.image_width, stored.image_height, stored.centre);
  if (orientation >= 5) std::swap(shown.image_width, shown.image_height);
  return shown;
}

void check_vignetting_size(const VignettingModel& model, int width, int height, const std::string& file) {
  if (width != model.image_width || height != model.image_height)
    throw InputError(fmt::format("{}: vignetting measured on {}x{} images, this one is {}x{}", file, model.image_width,
                                 model.image_height, width, height));
}

std::string aperture_mismatch(const VignettingModel& model, double f_number, const std::string& model_file,
                              const std::string& images) {
  if (!(model.f_number > 0 && f_number > 0)) return "";
  // A sixth of a stop in f-number is a factor 2^(1/12): EXIF's rounded values (2.8 for
  // 2.83) stay within it.
  if (std::abs(std::log2(f_number / model.f_number)) <= 1.0 / 12 + 1e-9) return "";
  return fmt::format("{} was measured at f/{:g} and {} {} at f/{:g}: vignetting changes with the aperture, so the "
                     "correction is off (measure flats at this aperture)",
                     model_file, model.f_number, images, images.find(' ') == std::string::npos ? "is" : "are", f_number);
}

void correct_vignetting(RgbImage& image, const VignettingModel& model, const std::string& file) {
  check_vignetting_size(model, image.width, image.height, file);
  if (image.code_bits > 0) throw InputError(file + ": vignetting is corrected on radiance, not on camera codes");
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const float gain = float(1.0 / relative_illumination(model, x, y));
      float* p = &image.rgb[(size_t(y) * size_t(image.width) + size_t(x)) * 3];
      p[0] *= gain;
      p[1] *= gain;
      p[2] *= gain;
    }
}

std::vector<float> inverse_vignetting_at(const VignettingModel& model, const std::vector<float>& src_x,
                                         const std::vector<float>& src_y) {
  std::vector<float> gain(src_x.size(), 1.0f);
  for (size_t i = 0; i < src_x.size() && i < src_y.size(); ++i)
    if (std::isfinite(src_x[i]) && std::isfinite(src_y[i]))
      gain[i] = float(1.0 / relative_illumination(model, src_x[i] - 0.5, src_y[i] - 0.5));
  return gain;
}

void save_vignetting(const std::string& path, const VignettingModel& m) {
  nlohmann::json j;
  j["format"] = "lightprobe.vignetting/1";
  j["model"] = "V = 1 + k1 r^2 + k2 r^4 + k3 r^6 + k4 r^8 + k5 r^10, r = |p - centre| / radius_px";
  j["image_width"] = m.image_width;
  j["image_height"] = m.image_height;
  j["centre"] = m.centre;
  j["centre_note"] = "px, pixel centres at integers";
  j["centre_from"] = m.centre_from;
  j["radius_px"] = m.radius_px;
  j["k"] = m.k;
  j["terms"] = m.terms;
  j["max_radius"] = m.max_radius;
  j["max_radius_note"] = "the largest r the flats measured; beyond it V goes on along its tangent, never below half of V(max_radius)";
  j["rms_relative"] = m.rms_relative;
  j["edge_sigma_relative"] = m.edge_sigma_relative;
  j["flats"] = m.flats;
  j["blocks"] = m.blocks;
  j["blocks_dropped"] = m.blocks_dropped;
  j["f_number"] = m.f_number;
  write_file_atomically(path, j.dump(2) + "\n");
}

VignettingModel load_vignetting(const std::string& path) {
  const nlohmann::json j = read_json_file(path);
  check_json_format(j, path, "lightprobe.vignetting/1");
  VignettingModel m;
  try {
    // As numbers first: 1e12 taken as an int is undefined, and came out negative.
    const double width = j.at("image_width").get<double>(), height = j.at("image_height").get<double>();
    if (!(width >= 1 && width <= 1e6 && height >= 1 && height <= 1e6 && width == std::floor(width) &&
          height == std::floor(height)))
      throw InputError(fmt::format("{}: image size {}x{} is not a camera's", path, width, height));
    m.image_width = int(width);
    m.image_height = int(height);
    m.centre = j.at("centre").get<std::array<double, 2>>();
    m.radius_px = j.at("radius_px").get<double>();
    const std::vector<double> k = j.at("k").get<std::vector<double>>();
    if (k.empty() || k.size() > size_t(kMaxTerms))
      throw InputError(fmt::format("{}: k has {} coefficients, 1 to {} expected", path, k.size(), kMaxTerms));
    std::copy(k.begin(), k.end(), m.k.begin());
    m.max_radius = j.at("max_radius").get<double>();
    m.terms = j.value("terms", int(k.size()));
    m.centre_from = j.value("centre_from", "fit");
    m.rms_relative = j.value("rms_relative", 0.0);
    m.edge_sigma_relative = j.value("edge_sigma_relative", 0.0);
    m.flats = j.value("flats", 0);
    m.blocks = j.value("blocks", size_t(0));
    m.blocks_dropped = j.value("blocks_dropped", size_t(0));
    m.f_number = j.value("f_number", 0.0);
  } catch (const nlohmann::json::exception& e) {
    throw InputError(json_field_problem(path, e));
  }
  // A lens's centre lies on its image; terms says how many of k were fitted.
  if (!(m.centre[0] >= -0.5 && m.centre[0] <= m.image_width - 0.5 && m.centre[1] >= -0.5 &&
        m.centre[1] <= m.image_height - 0.5 && m.radius_px > 0 && std::isfinite(m.radius_px) && m.max_radius > 0 &&
        m.max_radius <= 2 && m.terms >= 1 && m.terms <= kMaxTerms))
    throw InputError(path + ": centre (off the image), radius_px, max_radius or terms out of range");
  for (double k : m.k)
    if (!std::isfinite(k)) throw InputError(path + ": a coefficient k is not finite");
  if (const double r = implausible_radius(m.k, m.max_radius); r >= 0)
    throw InputError(fmt::format("{}: V = {:.3g} at r = {:.2f}: not a lens's falloff", path, polynomial(m.k, r * r), r));
  return m;
}

}  // namespace lp
