#include "hdr/response.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <sstream>

// hdr/CMakeLists.txt does not link Eigen3::Eigen; Eigen's headers include each other
// relatively, so the prefixed path works with the system include root alone.
#include <eigen3/Eigen/Sparse>
#include <eigen3/Eigen/SparseCholesky>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "core/tonemap.h"
#include "core/error.h"
#include "core/file_io.h"
#include "core/json_file.h"

namespace lp {
namespace {

int response_levels(const Bracket& b, int requested) {
  if (requested > 0) {
    if (requested < 2 || requested > 65536)
      throw InputError(fmt::format("response levels {} outside [2, 65536]", requested));
    return requested;
  }
  return b.bit_depth <= 8 ? (1 << b.bit_depth) : 1024;
}

inline int to_level(float v, int levels) {
  const float s = v * float(levels - 1) + 0.5f;
  if (!(s > 0.0f)) return 0;
  return std::min(int(s), levels - 1);
}

// A pixel the frame has no data for: masked invalid (RgbImage::valid).
bool no_data(const RgbImage& frame, size_t p) { return !frame.valid.empty() && !frame.valid[p]; }

bool is_colour(const RgbImage& f, size_t pixel, const std::array<uint8_t, 3>& colour) {
  const float* p = &f.rgb[3 * pixel];
  for (int c = 0; c < 3; ++c)
    if (std::lround(double(p[c]) * 255.0) != long(colour[c])) return false;
  return true;
}

// Van der Corput radical inverse in base b.
double radical_inverse(uint64_t i, uint64_t base) {
  double inv = 1.0 / double(base), f = inv, r = 0.0;
  while (i > 0) {
    r += f * double(i % base);
    i /= base;
    f *= inv;
  }
  return r;
}

// A camera's response cannot fall as the code rises; a recovered curve can, where few samples
// or inconsistent ones constrain it (deghost then refused it). Replaced per channel by its
// closest non-decreasing curve in least squares (pool-adjacent-violators), which leaves a
// curve that is already monotone as it is, then renormalised to g(levels/2) = 0.
void make_monotone(CameraResponse& r) {
  const size_t mid = size_t(r.levels / 2);
  for (auto& g : r.log_exposure) {
    std::vector<double> value, weight;
    std::vector<size_t> count;
    for (float v : g) {
      value.push_back(v), weight.push_back(1), count.push_back(1);
      while (value.size() > 1 && value[value.size() - 2] > value.back()) {
        const size_t t = value.size() - 1;
        value[t - 1] = (value[t - 1] * weight[t - 1] + value[t] * weight[t]) / (weight[t - 1] + weight[t]);
        weight[t - 1] += weight[t], count[t - 1] += count[t];
        value.pop_back(), weight.pop_back(), count.pop_back();
      }
    }
    size_t z = 0;
    for (size_t b = 0; b < value.size(); ++b)
      for (size_t m = 0; m < count[b]; ++m) g[z++] = float(value[b]);
    const float at_mid = g.size() > mid ? g[mid] : 0.f;
    for (float& v : g) v -= at_mid;
  }
}

}  // namespace

CameraResponse srgb_response(int levels) {
  if (levels < 2 || levels > 65536) throw InputError(fmt::format("response levels {} outside [2, 65536]", levels));
  auto decode = [&](double z) { return srgb_to_linear(z / double(levels - 1)); };
  CameraResponse r;
  r.levels = levels;
  const double mid = decode(levels / 2);
  for (auto& g : r.log_exposure) {
    g.resize(size_t(levels));
    for (int z = 0; z < levels; ++z) g[size_t(z)] = float(std::log(decode(std::max(double(z), 0.5)) / mid));
  }
  return r;
}

CameraResponse linear_response(int levels) {
  if (levels < 2 || levels > 65536) throw InputError(fmt::format("response levels {} outside [2, 65536]", levels));
  CameraResponse r;
  r.levels = levels;
  r.linear = true;
  const double mid = levels / 2;
  for (auto& g : r.log_exposure) {
    g.resize(size_t(levels));
    for (int z = 0; z < levels; ++z) g[size_t(z)] = float(std::log(std::max(double(z), 0.5) / mid));
  }
  return r;
}

void check_response(const CameraResponse& r, const std::string& who) {
  if (r.levels < 2 || r.levels > 65536)
    throw InputError(fmt::format("{}: response has {} levels (expected 2 to 65536)", who, r.levels));
  for (int c = 0; c < 3; ++c) {
    const auto& g = r.log_exposure[size_t(c)];
    if (g.size() != size_t(r.levels))
      throw InputError(fmt::format("{}: channel {} of the response has {} values for {} levels", who, c, g.size(),
                                   r.levels));
    for (size_t z = 0; z < g.size(); ++z)
      if (!std::isfinite(g[z]))
        throw InputError(fmt::format("{}: response value at channel {} level {} is not finite", who, c, z));
  }
}

std::vector<size_t> sample_pixels(const Bracket& b, int count, const std::optional<std::array<uint8_t, 3>>& ignore) {
  check_bracket(b);
  const size_t npix = size_t(b.width()) * size_t(b.height());
  if (count <= 0) return {};
  const size_t want = std::min(size_t(count), npix);
  // Candidates: Halton points over the image, many more than wanted.
  const size_t ncand = std::min(npix, std::max<size_t>(64 * want, 4096));
  struct Candidate {
    size_t pixel;
    double log_e;
  };
  std::vector<Candidate> cands;
  cands.reserve(ncand);
  std::vector<uint8_t> taken(npix, 0);
  for (uint64_t i = 1; cands.size() < ncand && i < 4 * uint64_t(ncand) + 16; ++i) {
    const int x = std::min(b.width() - 1, int(radical_inverse(i, 2) * b.width()));
    const int y = std::min(b.height() - 1, int(radical_inverse(i, 3) * b.height()));
    const size_t p = size_t(y) * size_t(b.width()) + size_t(x);
    if (taken[p]) continue;
    taken[p] = 1;
    bool skip = false;
    double best_d = 2.0, log_e = 0.0;
    bool informative = false;
    for (size_t k = 0; k < b.frames.size() && !skip; ++k) {
      // Ignored colour, or no data (an aligned frame's registration border, a transparent pixel).
      if ((ignore && is_colour(b.frames[k], p, *ignore)) || no_data(b.frames[k], p)) skip = true;
      const float* v = &b.frames[k].rgb[3 * p];
      const double m = (double(v[0]) + v[1] + v[2]) / 3.0;
      if (m > 0.02 && m < 0.98) informative = true;
      if (std::abs(m - 0.5) < best_d) {
        best_d = std::abs(m - 0.5);
        log_e = std::log(m + 1e-3) - std::log(b.exposure_seconds[k]);
      }
    }
    if (skip || !informative) continue;
    cands.push_back({p, log_e});
  }
  std::vector<size_t> out;
  if (cands.empty()) return out;
  double lo = cands[0].log_e, hi = lo;
  for (const auto& c : cands) lo = std::min(lo, c.log_e), hi = std::max(hi, c.log_e);
  const size_t nbins = want;
  std::vector<uint8_t> bin_full(nbins, 0), used(cands.size(), 0);
  for (size_t i = 0; i < cands.size() && out.size() < want; ++i) {
    const size_t bin = hi > lo ? std::min(nbins - 1, size_t((cands[i].log_e - lo) / (hi - lo) * double(nbins))) : 0;
    if (bin_full[bin]) continue;
    bin_full[bin] = 1;
    used[i] = 1;
    out.push_back(cands[i].pixel);
  }
  // Radiance bins without candidates: fill up in Halton (spatially stratified) order.
  for (size_t i = 0; i < cands.size() && out.size() < want; ++i)
    if (!used[i]) out.push_back(cands[i].pixel);
  return out;
}

CameraResponse recover_debevec(const Bracket& b, const DebevecOptions& o) {
  check_bracket(b);
  if (!(o.lambda >= 0.0) || !std::isfinite(o.lambda)) throw InputError("Debevec lambda must be finite and >= 0");
  if (o.samples < 2) throw InputError(fmt::format("Debevec samples {} is below 2", o.samples));
  const int n = response_levels(b, o.levels);
  const std::vector<size_t> pixels = sample_pixels(b, o.samples, o.ignore_colour);
  if (pixels.size() < 2) throw InputError(fmt::format("{}: too few usable pixels to recover a response",
                                                      b.paths.empty() ? "bracket" : b.paths[0]));
  const size_t ns = pixels.size();
  const int mid = n / 2;
  // Hat weight on the 8-bit scale, so that lambda means what it means in the paper.
  const double s = double(n - 1) / 255.0;
  auto hat = [&](int z) {
    const double z8 = z / s;
    return z8 <= 127.5 ? z8 : 255.0 - z8;
  };
  // Second differences shrink by s^2 at finer level spacing and there are s times more of
  // them: scale each smoothness row by s^2 / sqrt(s) to keep the paper's balance.
  const double smooth_scale = o.lambda * s * s / std::sqrt(s);

  CameraResponse r;
  r.levels = n;
  const size_t nu = size_t(n) + ns;
  const size_t nf = b.frames.size();
  for (int c = 0; c < 3; ++c) {
    // The observations: sample i seen at level z in frame k, with its hat weight.
    struct Observation {
      int i, z;
      double w, log_t;
      bool used = true;
    };
    std::vector<Observation> obs;
    obs.reserve(ns * nf);
    for (size_t i = 0; i < ns; ++i)
      for (size_t k = 0; k < nf; ++k) {
        const int z = to_level(b.frames[k].rgb[3 * pixels[i] + size_t(c)], n);
        const double w = hat(z);
        if (w > 0.0) obs.push_back({int(i), z, w, std::log(b.exposure_seconds[k])});
      }
    const auto solve = [&] {
      std::vector<Eigen::Triplet<double>> trip;
      Eigen::VectorXd atb = Eigen::VectorXd::Zero(Eigen::Index(nu));
      trip.reserve(obs.size() * 4 + size_t(n) * 9 + ns + size_t(n) + 1);
      auto add_row = [&](const int* idx, const double* coef, int m, double rhs) {
        for (int a = 0; a < m; ++a) {
          for (int bb = 0; bb < m; ++bb) trip.emplace_back(idx[a], idx[bb], coef[a] * coef[bb]);
          atb[idx[a]] += coef[a] * rhs;
        }
      };
      for (const Observation& o : obs) {
        if (!o.used) continue;
        const int idx[2] = {o.z, n + o.i};
        const double coef[2] = {o.w, -o.w};
        add_row(idx, coef, 2, o.w * o.log_t);
      }
      {
        const int idx[1] = {mid};
        const double coef[1] = {1.0};
        add_row(idx, coef, 1, 0.0);
      }
      for (int z = 1; z < n - 1; ++z) {
        const double w = smooth_scale * hat(z);
        const int idx[3] = {z - 1, z, z + 1};
        const double coef[3] = {w, -2.0 * w, w};
        add_row(idx, coef, 3, 0.0);
      }
      // A sample seen in no usable frame would leave its ln E free: pin it weakly to 0.
      for (size_t i = 0; i < ns; ++i) trip.emplace_back(n + int(i), n + int(i), 1e-9);
      // Levels outside every sample and every smoothness row (n = 2): pin weakly too.
      for (int z = 0; z < n; ++z) trip.emplace_back(z, z, 1e-12);
      Eigen::SparseMatrix<double> ata(static_cast<Eigen::Index>(nu), static_cast<Eigen::Index>(nu));
      ata.setFromTriplets(trip.begin(), trip.end());
      Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver(ata);
      if (solver.info() != Eigen::Success) throw std::runtime_error("recover_debevec: normal equations not factorable");
      return Eigen::VectorXd(solver.solve(atb));
    };
    Eigen::VectorXd x = solve();
    // Observations the model cannot explain (a pixel that moved between frames: a person, a
    // cloud, the camera's own motion) pulled the curve by their square: on a synthetic bracket
    // with a moving object the blue curve fell by 2 (ln units) over codes 45-65. They are
    // dropped (beyond 8 robust sigmas: on the clean synthetic brackets of `eval hdr`, linear,
    // gamma and S-curve, none is) and the curve solved again, twice at most.
    for (int round = 0; round < o.outlier_rounds; ++round) {
      // Each residual as the fit weighs it (hat weight times ln units): an observation near
      // black or white, which the fit barely heeds and a smooth curve may miss by its shape
      // (an S-curve's ends), is not taken for motion.
      const auto weighted_residual = [&](const Observation& ob) { return ob.w * std::abs(x[ob.z] - x[n + ob.i] - ob.log_t); };
      std::vector<double> abs_res;
      abs_res.reserve(obs.size());
      for (const Observation& ob : obs)
        if (ob.used) abs_res.push_back(weighted_residual(ob));
      if (abs_res.size() < 8) break;
      std::nth_element(abs_res.begin(), abs_res.begin() + long(abs_res.size() / 2), abs_res.end());
      const double sigma = 1.4826 * abs_res[abs_res.size() / 2];
      const double limit = o.outlier_sigmas * sigma;
      size_t dropped = 0;
      for (Observation& ob : obs)
        if (ob.used && weighted_residual(ob) > limit) ob.used = false, ++dropped;
      if (dropped == 0) break;
      x = solve();
    }
    auto& g = r.log_exposure[size_t(c)];
    g.resize(size_t(n));
    for (int z = 0; z < n; ++z) g[size_t(z)] = float(x[z] - x[mid]);
  }
  make_monotone(r);
  check_response(r, "recover_debevec");
  return r;
}

CameraResponse recover_robertson(const Bracket& b, const RobertsonOptions& o) {
  check_bracket(b);
  if (o.max_iterations < 1) throw InputError("Robertson max_iterations must be >= 1");
  const int n = response_levels(b, o.levels);
  const size_t npix = size_t(b.width()) * size_t(b.height());
  const size_t nf = b.frames.size();
  const int mid = n / 2;
  const double centre = (n - 1) / 2.0;
  std::vector<double> w(static_cast<size_t>(n));
  for (int z = 0; z < n; ++z) w[size_t(z)] = std::exp(-4.0 * (z - centre) * (z - centre) / (centre * centre));
  // Clipped codes bound the exposure, they do not measure it (a deviation from the paper,
  // whose weight is small but not zero there).
  w[0] = w[size_t(n - 1)] = 0.0;
  constexpr uint16_t kSkip = 0xffff;  // an ignored pixel/frame pair (n <= 65535 levels here)
  const int nn = std::min(n, 65535);
  std::vector<uint16_t> lv(nf * npix);
  CameraResponse r;
  r.levels = n;
  for (int c = 0; c < 3; ++c) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, npix, 4096), [&](const tbb::blocked_range<size_t>& rg) {
      for (size_t k = 0; k < nf; ++k)
        for (size_t p = rg.begin(); p < rg.end(); ++p)
          lv[k * npix + p] = ((o.ignore_colour && is_colour(b.frames[k], p, *o.ignore_colour)) || no_data(b.frames[k], p))
                                 ? kSkip
                                 : uint16_t(to_level(b.frames[k].rgb[3 * p + size_t(c)], nn));
    });
    std::vector<double> I(static_cast<size_t>(n));
    for (int z = 0; z < n; ++z) I[size_t(z)] = std::max(double(z), 0.5) / mid;
    struct Acc {
      std::vector<double> sum;
      std::vector<uint64_t> cnt;
    };
    for (int it = 0; it < o.max_iterations; ++it) {
      tbb::enumerable_thread_specific<Acc> accs([&] { return Acc{std::vector<double>(size_t(n), 0.0),
                                                                 std::vector<uint64_t>(size_t(n), 0)}; });
      tbb::parallel_for(tbb::blocked_range<size_t>(0, npix, 4096), [&](const tbb::blocked_range<size_t>& rg) {
        Acc& acc = accs.local();
        for (size_t p = rg.begin(); p < rg.end(); ++p) {
          double num = 0.0, den = 0.0;
          for (size_t k = 0; k < nf; ++k) {
            const uint16_t z = lv[k * npix + p];
            if (z == kSkip) continue;
            const double t = b.exposure_seconds[k];
            num += w[z] * t * I[z];
            den += w[z] * t * t;
          }
          if (!(den > 0.0)) continue;
          const double x = num / den;
          for (size_t k = 0; k < nf; ++k) {
            const uint16_t z = lv[k * npix + p];
            if (z == kSkip) continue;
            acc.sum[z] += b.exposure_seconds[k] * x;
            ++acc.cnt[z];
          }
        }
      });
      std::vector<double> sum(size_t(n), 0.0);
      std::vector<uint64_t> cnt(size_t(n), 0);
      for (const Acc& a : accs)
        for (int z = 0; z < n; ++z) sum[size_t(z)] += a.sum[size_t(z)], cnt[size_t(z)] += a.cnt[size_t(z)];
      // New curve; unobserved levels interpolated in the log domain between observed ones.
      std::vector<double> g(size_t(n), std::nan(""));
      std::vector<int> seen;
      for (int z = 0; z < n; ++z)
        if (cnt[size_t(z)] > 0 && sum[size_t(z)] > 0.0) {
          g[size_t(z)] = std::log(sum[size_t(z)] / double(cnt[size_t(z)]));
          seen.push_back(z);
        }
      if (seen.empty()) throw InputError(fmt::format("{}: no usable pixels to recover a response",
                                                     b.paths.empty() ? "bracket" : b.paths[0]));
      for (int z = 0; z < n; ++z) {
        if (!std::isnan(g[size_t(z)])) continue;
        const auto hi = std::lower_bound(seen.begin(), seen.end(), z);
        if (hi == seen.begin()) {
          g[size_t(z)] = g[size_t(seen.front())];
        } else if (hi == seen.end()) {
          g[size_t(z)] = g[size_t(seen.back())];
        } else {
          const int z0 = *(hi - 1), z1 = *hi;
          const double a = double(z - z0) / double(z1 - z0);
          g[size_t(z)] = (1 - a) * g[size_t(z0)] + a * g[size_t(z1)];
        }
      }
      const double g_mid = g[size_t(mid)];
      double change = 0.0;
      for (int z = 0; z < n; ++z) {
        const double g_old = std::log(std::max(I[size_t(z)], 1e-300));
        const double step = (g[size_t(z)] - g_mid) - g_old;
        change = std::max(change, std::abs(step));
        I[size_t(z)] = std::exp(g_old + step);
      }
      const double i_mid = I[size_t(mid)];
      for (double& v : I) v /= i_mid;
      if (change < o.threshold) break;
    }
    auto& g = r.log_exposure[size_t(c)];
    g.resize(size_t(n));
    for (int z = 0; z < n; ++z) g[size_t(z)] = float(std::log(I[size_t(z)]));
  }
  make_monotone(r);
  check_response(r, "recover_robertson");
  return r;
}

void save_response(const std::string& path, const CameraResponse& r) {
  check_response(r, path);
  nlohmann::json j;
  j["format"] = "lightprobe.response/1";
  j["levels"] = r.levels;
  j["linear"] = r.linear;
  j["convention"] = "g(z) = ln(E dt), g(levels/2) = 0";
  j["log_exposure"] = {{"r", r.log_exposure[0]}, {"g", r.log_exposure[1]}, {"b", r.log_exposure[2]}};
  write_file_atomically(path, j.dump(1) + "\n");
}

CameraResponse load_response(const std::string& path) {
  const nlohmann::json j = read_json_file(path);
  check_json_format(j, path, "lightprobe.response/1");
  CameraResponse r;
  try {
    // An integer first: get<int>() of a float beyond int (1e30) is undefined behaviour.
    const auto& levels = j.at("levels");
    if (!levels.is_number_integer() || levels.get<int64_t>() < 0 || levels.get<int64_t>() > INT32_MAX)
      throw InputError(fmt::format("{}: \"levels\" is {}, not a count of code values", path, levels.dump().substr(0, 40)));
    r.levels = levels.get<int>();
    r.linear = j.value("linear", false);
    const auto& le = j.at("log_exposure");
    const char* names[3] = {"r", "g", "b"};
    for (int c = 0; c < 3; ++c) r.log_exposure[size_t(c)] = le.at(names[c]).get<std::vector<float>>();
  } catch (const nlohmann::json::exception& e) {
    throw InputError(json_field_problem(path, e));
  }
  check_response(r, path);
  return r;
}

}  // namespace lp
