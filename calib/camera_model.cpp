#include "calib/camera_model.h"

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cctype>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>

#include "calib/lens_model.h"
#include "calib/opencv_storage_check.h"
#include "core/error.h"
#include "core/warnings.h"
#include "core/file_io.h"
#include "core/image_io.h"

// mrcal.h is a C header without extern "C".
extern "C" {
#include <mrcal/mrcal.h>
}

namespace lp {
namespace {

// ---- lens models ----------------------------------------------------------------------

// The parsed model of a name, with mrcal's form for mrcal models; the last name is cached
// per thread because project() is called per pixel and the splined models' configuration
// is parsed with sscanf. nullptr for a name the table does not know.
struct ParsedLens {
  LensModel model;
  mrcal_lensmodel_t mrcal;
};
const ParsedLens* parsed_lens(const std::string& name) {
  thread_local std::string cached_name;
  thread_local std::optional<ParsedLens> cached;
  if (name != cached_name || cached_name.empty()) {
    cached_name = name;
    cached.reset();
    if (auto m = LensModel::try_parse(name)) {
      mrcal_lensmodel_t lm{};
      if (!m->is_mrcal() || mrcal_lensmodel_from_name(&lm, name.c_str())) cached = ParsedLens{*m, lm};
    }
  }
  return cached ? &*cached : nullptr;
}

const ParsedLens& parsed_lens_or_throw(const std::string& name) {
  if (const ParsedLens* p = parsed_lens(name)) return *p;
  LensModel::parse(name);  // throws the table's one-line message
  throw InputError("unknown lens model '" + name + "'");
}

void check_intrinsics(const CameraModel& m) {
  const int n = intrinsics_count(m.lensmodel);
  if (int(m.intrinsics.size()) != n)
    throw InputError(m.lensmodel + ": " + std::to_string(m.intrinsics.size()) + " intrinsics, the model takes " +
                     std::to_string(n));
}

// ---- Kannala-Brandt (cv::fisheye) -----------------------------------------------------

inline double kb_distort(const double* k, double t) {
  const double t2 = t * t;
  return t * (1 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
}
inline double kb_derivative(const double* k, double t) {
  const double t2 = t * t;
  return 1 + t2 * (3 * k[0] + t2 * (5 * k[1] + t2 * (7 * k[2] + t2 * 9 * k[3])));
}

// Largest theta in (0, pi] up to which theta_d(theta) increases: the model's domain.
// Cached per thread for the last 16 coefficient sets (project/unproject run per pixel,
// often alternating between a few models: projection differences, numeric Jacobians).
double kb_max_theta(const double* k) {
  struct Entry {
    std::array<double, 4> k{NAN, NAN, NAN, NAN};
    double max = 0;
  };
  thread_local std::array<Entry, 16> cache;
  thread_local size_t next = 0;
  for (const Entry& e : cache)
    if (std::equal(k, k + 4, e.k.begin())) return e.max;
  constexpr int kSteps = 2048;
  double max_theta = M_PI;
  for (int i = 1; i <= kSteps; ++i) {
    const double t = M_PI * i / kSteps;
    if (!(kb_derivative(k, t) > 0)) {
      // refine the first zero of the derivative by bisection
      double lo = M_PI * (i - 1) / kSteps, hi = t;
      for (int it = 0; it < 60; ++it) {
        const double mid = 0.5 * (lo + hi);
        (kb_derivative(k, mid) > 0 ? lo : hi) = mid;
      }
      max_theta = lo;
      break;
    }
  }
  Entry& e = cache[next];
  next = (next + 1) % cache.size();
  std::copy(k, k + 4, e.k.begin());
  e.max = max_theta;
  return max_theta;
}

std::optional<Pixel> kb_project(const double* p, Vec3 d) {
  const double* k = p + 4;
  const double rho = std::hypot(d.x, d.y);
  const double theta = std::atan2(rho, d.z);
  if (!(rho > 0 || d.z > 0)) return std::nullopt;  // zero vector or exactly backwards
  if (!(theta <= kb_max_theta(k))) return std::nullopt;
  if (rho == 0) return Pixel{p[2], p[3]};
  const double s = kb_distort(k, theta) / rho;
  return Pixel{p[0] * s * d.x + p[2], p[1] * s * d.y + p[3]};
}

std::optional<Vec3> kb_unproject(const double* p, Pixel q, int* iterations = nullptr) {
  const double* k = p + 4;
  const double a = (q.x - p[2]) / p[0], b = (q.y - p[3]) / p[1];
  const double theta_d = std::hypot(a, b);
  if (!std::isfinite(theta_d)) return std::nullopt;
  if (theta_d == 0) return Vec3{0, 0, 1};
  const double hi0 = kb_max_theta(k);
  if (!(kb_distort(k, hi0) >= theta_d)) return std::nullopt;  // beyond the lens' image circle
  // Safeguarded Newton on the monotonic branch [0, hi0]: a step that leaves the bracket
  // bisects instead. It stops once theta_d(t) matches to rounding, or when a step lands back
  // on a bracket end already evaluated (rounding makes f change sign within a few ulps where
  // the derivative is small, near hi0). Until stop 47 an exact root (f = 0) or a step onto the
  // bracket's end counted as leaving it, and the bisection that followed took 20-50 more
  // iterations to come back: 27 a pixel on average over Fisheye190deg's fit, 4.4 now, the
  // angle within 1.3e-14 relative of before (docs/calibration.md, "Stop 47").
  const double matched = 4 * std::numeric_limits<double>::epsilon() * theta_d;
  double lo = 0, hi = hi0, t = std::min(theta_d, hi0);
  int it = 0;
  for (; it < 100; ++it) {
    const double f = kb_distort(k, t) - theta_d;
    if (std::abs(f) <= matched) break;
    if (f > 0) hi = t; else lo = t;
    const double df = kb_derivative(k, t);
    double next = t - f / df;
    if ((next == lo || next == hi) && hi - lo < 1e-12 * std::max(1.0, t)) break;
    if (!(next >= lo && next <= hi)) next = 0.5 * (lo + hi);
    const double step = std::abs(next - t);
    t = next;
    if (step < 1e-15 * std::max(1.0, t) || hi - lo < 1e-15) break;
  }
  if (iterations) *iterations = it;
  const double s = std::sin(t) / theta_d;
  return Vec3{s * a, s * b, std::cos(t)};
}

// ---- Mei's unified model (cv::omnidir) ------------------------------------------------

// Radial-tangential distortion of normalised coordinates (k1 k2 p1 p2), as cv::omnidir.
inline void mei_distort(const double* D, double xu, double yu, double* xd, double* yd) {
  const double r2 = xu * xu + yu * yu, r4 = r2 * r2;
  const double radial = 1 + D[0] * r2 + D[1] * r4;
  *xd = xu * radial + 2 * D[2] * xu * yu + D[3] * (r2 + 2 * xu * xu);
  *yd = yu * radial + D[2] * (r2 + 2 * yu * yu) + 2 * D[3] * xu * yu;
}

// Points on the unit sphere below this z cannot be imaged uniquely by the unified model:
// z + xi > 0 for xi <= 1; for xi > 1 the projection folds over at z = -1/xi.
inline double mei_min_z(double xi) { return xi <= 1 ? -xi : -1 / xi; }

std::optional<Pixel> mei_project(const double* p, Vec3 d) {
  const double xi = p[4];
  const double n = length(d);
  if (!(n > 0) || !std::isfinite(n)) return std::nullopt;
  const Vec3 s = (1 / n) * d;
  if (!(s.z > mei_min_z(xi))) return std::nullopt;
  const double w = s.z + xi;
  if (!(w > 0)) return std::nullopt;
  double xd, yd;
  mei_distort(p + 5, s.x / w, s.y / w, &xd, &yd);
  return Pixel{p[0] * xd + p[2], p[1] * yd + p[3]};
}

std::optional<Vec3> mei_unproject(const double* p, Pixel q) {
  const double xi = p[4];
  const double* D = p + 5;
  const double xd = (q.x - p[2]) / p[0], yd = (q.y - p[3]) / p[1];
  if (!std::isfinite(xd) || !std::isfinite(yd)) return std::nullopt;
  // Undistort by Newton on the 2x2 system (cv::omnidir::undistortPoints iterates a fixed
  // point; Newton converges to full precision and from further out).
  double xu = xd, yu = yd;
  bool converged = false;
  for (int it = 0; it < 50; ++it) {
    double fx, fy;
    mei_distort(D, xu, yu, &fx, &fy);
    fx -= xd;
    fy -= yd;
    const double r2 = xu * xu + yu * yu;
    const double radial = 1 + D[0] * r2 + D[1] * r2 * r2;
    const double dradial = 2 * D[0] + 4 * D[1] * r2;  // d radial / d (r2)
    const double j00 = radial + xu * dradial * xu + 2 * D[2] * yu + D[3] * 6 * xu;
    const double j01 = xu * dradial * yu + 2 * D[2] * xu + D[3] * 2 * yu;
    const double j10 = yu * dradial * xu + D[2] * 2 * xu + 2 * D[3] * yu;
    const double j11 = radial + yu * dradial * yu + D[2] * 6 * yu + 2 * D[3] * xu;
    const double det = j00 * j11 - j01 * j10;
    if (!(std::abs(det) > 1e-300)) break;
    const double dx = (j11 * fx - j01 * fy) / det, dy = (-j10 * fx + j00 * fy) / det;
    xu -= dx;
    yu -= dy;
    if (!std::isfinite(xu) || !std::isfinite(yu)) break;
    if (std::abs(dx) + std::abs(dy) < 1e-15 * (1 + std::abs(xu) + std::abs(yu))) {
      converged = true;
      break;
    }
  }
  if (!converged) {
    double cx, cy;  // accept a solution that reprojects within ~1e-12
    mei_distort(D, xu, yu, &cx, &cy);
    if (!(std::hypot(cx - xd, cy - yd) < 1e-12 * (1 + std::hypot(xd, yd)))) return std::nullopt;
  }
  // Closed-form lift to the unit sphere.
  const double r2 = xu * xu + yu * yu;
  const double disc = 1 + (1 - xi * xi) * r2;
  if (!(disc >= 0)) return std::nullopt;
  const double f = (xi + std::sqrt(disc)) / (r2 + 1);
  const Vec3 s{f * xu, f * yu, f - xi};
  if (!(s.z > mei_min_z(xi) - 1e-12)) return std::nullopt;
  return normalize(s);
}

// ---- plumb_bob: OpenCV's radial-tangential model (mrcal's LENSMODEL_OPENCV4/5) ------------

// plumb_bob's distortion of normalised coordinates and its Jacobian, D = k1 k2 p1 p2 k3 (k3
// zero for OpenCV4): radial 1 + k1 r2 + k2 r4 + k3 r6, tangential p1 p2. Only these two models
// are unprojected here (see unproject), so the rational and thin-prism terms are left out.
inline void plumb_bob_distort(const double* D, double x, double y, double* xd, double* yd, double J[4]) {
  const double r2 = x * x + y * y, r4 = r2 * r2, r6 = r4 * r2;
  const double radial = 1 + D[0] * r2 + D[1] * r4 + D[4] * r6;
  const double dradial = D[0] + 2 * D[1] * r2 + 3 * D[4] * r4;  // d radial / d r2
  *xd = x * radial + 2 * D[2] * x * y + D[3] * (r2 + 2 * x * x);
  *yd = y * radial + D[2] * (r2 + 2 * y * y) + 2 * D[3] * x * y;
  J[0] = radial + 2 * x * x * dradial + 2 * D[2] * y + 6 * D[3] * x;  // dxd/dx
  J[1] = 2 * x * y * dradial + 2 * D[2] * x + 2 * D[3] * y;           // dxd/dy
  J[2] = J[1];                                                        // dyd/dx
  J[3] = radial + 2 * y * y * dradial + 6 * D[2] * y + 2 * D[3] * x;  // dyd/dy
}

// Points between the axis and an unprojected point where the distortion must not fold.
constexpr int kSheetSamples = 16;

}  // namespace

// The ray of pixel q under plumb_bob with `ndist` (4 or 5) distortion coefficients, by Newton on
// the 2 x 2 distortion from the distorted point: converges in a few steps to the rounding of
// the model. mrcal unprojects these models with a dogleg solve per pixel, which was a third of
// a forced calibration's CPU (docs/calibration.md, stop 40). nullopt where Newton does not
// converge to a point of the distortion's central sheet (Jacobian determinant > 0 at the point
// and at kSheetSamples points between it and the axis): beyond the fold the polynomial images
// the answer is ambiguous, and the caller asks mrcal instead.
std::optional<Vec3> detail::kb_unproject(const double* intrinsics, Pixel pixel, int* iterations) {
  return lp::kb_unproject(intrinsics, pixel, iterations);
}

std::optional<Vec3> detail::opencv_unproject(const double* p, int ndist, Pixel q) {
  if (ndist != 4 && ndist != 5) return std::nullopt;
  double D[5] = {};
  std::copy(p + 4, p + 4 + ndist, D);
  const double xd = (q.x - p[2]) / p[0], yd = (q.y - p[3]) / p[1];
  if (!std::isfinite(xd) || !std::isfinite(yd)) return std::nullopt;
  double x = xd, y = yd;
  for (int it = 0; it < 50; ++it) {
    double fx, fy, J[4];
    plumb_bob_distort(D, x, y, &fx, &fy, J);
    fx -= xd;
    fy -= yd;
    const double det = J[0] * J[3] - J[1] * J[2];
    if (!(det > 0)) return std::nullopt;
    const double dx = (J[3] * fx - J[1] * fy) / det, dy = (-J[2] * fx + J[0] * fy) / det;
    x -= dx;
    y -= dy;
    if (!std::isfinite(x) || !std::isfinite(y)) return std::nullopt;
    if (std::abs(dx) + std::abs(dy) < 1e-15 * (1 + std::abs(x) + std::abs(y))) {
      plumb_bob_distort(D, x, y, &fx, &fy, J);
      if (!(std::hypot(fx - xd, fy - yd) < 1e-12 * (1 + std::hypot(xd, yd)))) return std::nullopt;
      // On the central sheet: the distortion does not fold between the axis and the point.
      for (int k = 1; k <= kSheetSamples; ++k) {
        const double t = double(k) / kSheetSamples;
        double ux, uy;
        plumb_bob_distort(D, t * x, t * y, &ux, &uy, J);
        if (!(J[0] * J[3] - J[1] * J[2] > 0)) return std::nullopt;
      }
      return normalize(Vec3{x, y, 1});
    }
  }
  return std::nullopt;
}

namespace {

// ---- text helpers ---------------------------------------------------------------------

std::string g17(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string read_text(const std::string& path) { return read_text_file(path); }

bool ends_with(const std::string& s, const std::string& suffix) {
  if (s.size() < suffix.size()) return false;
  std::string tail = s.substr(s.size() - suffix.size());
  std::transform(tail.begin(), tail.end(), tail.begin(), [](unsigned char c) { return std::tolower(c); });
  return tail == suffix;
}

// What every model file holds, read or written: finite intrinsics, positive focal lengths
// (fx fy lead every lens model's intrinsics) and a positive image size.
void check_model_file(const std::string& path, const CameraModel& m) {
  for (double v : m.intrinsics)
    if (!std::isfinite(v)) throw InputError(path + ": " + m.lensmodel + " has a non-finite intrinsic");
  for (size_t k = 0; k < 2 && k < m.intrinsics.size(); ++k)
    if (!(m.intrinsics[k] > 0))
      throw InputError(path + ": focal length " + (k ? "fy" : "fx") + " = " + g17(m.intrinsics[k]) + " is not positive");
  if (m.width <= 0 || m.height <= 0)
    throw InputError(path + ": image size " + std::to_string(m.width) + "x" + std::to_string(m.height) +
                     " is not positive");
}

// Value after "# <key> =" in a comment line of a .cameramodel we wrote; 0 when absent.
double comment_value(const std::string& text, const std::string& key) {
  const std::string tag = "# " + key + " = ";
  const size_t at = text.find(tag);
  if (at == std::string::npos) return 0;
  return std::strtod(text.c_str() + at + tag.size(), nullptr);
}


// A light parse of the .cameramodel text (a Python dict literal) that finds what mrcal's
// C reader would reject, so that we can name the problem ourselves: the C reader prints
// its complaints to stderr and the library prints nothing. Returns "" when the text
// looks readable, else the problem.
std::string precheck_cameramodel(const std::string& text) {
  size_t i = 0;
  const size_t n = text.size();
  auto skip = [&] {
    while (i < n) {
      if (std::isspace(static_cast<unsigned char>(text[i]))) ++i;
      else if (text[i] == '#') while (i < n && text[i] != '\n') ++i;
      else break;
    }
  };
  auto string_at = [&](std::string* out) {
    const char quote = text[i];
    const size_t end = text.find(quote, i + 1);
    if (end == std::string::npos) return false;
    *out = text.substr(i + 1, end - i - 1);
    i = end + 1;
    return true;
  };
  // Numbers of a (possibly nested) list, flattened.
  std::function<bool(std::vector<double>*)> list_at = [&](std::vector<double>* out) {
    ++i;  // '['
    for (;;) {
      skip();
      if (i >= n) return false;
      if (text[i] == ']') {
        ++i;
        return true;
      }
      if (text[i] == '[') {
        if (!list_at(out)) return false;
      } else {
        char* end = nullptr;
        const double v = std::strtod(text.c_str() + i, &end);
        if (end == text.c_str() + i) return false;
        out->push_back(v);
        i = size_t(end - text.c_str());
      }
      skip();
      if (i < n && text[i] == ',') ++i;
    }
  };
  skip();
  if (i >= n || text[i] != '{') return "does not start with '{'";
  ++i;
  std::string lensmodel;
  std::vector<double> intrinsics, imagersize;
  bool have_lensmodel = false, have_intrinsics = false, have_imagersize = false;
  for (;;) {
    skip();
    if (i >= n) return "ends before its closing '}'";
    if (text[i] == '}') break;
    std::string key;
    if ((text[i] != '\'' && text[i] != '"') || !string_at(&key)) return "malformed key";
    skip();
    if (i >= n || text[i] != ':') return "no ':' after '" + key + "'";
    ++i;
    skip();
    if (i >= n) return "no value for '" + key + "'";
    std::vector<double> values;
    std::string str;
    if (text[i] == 'b' && i + 1 < n && (text[i + 1] == '\'' || text[i + 1] == '"')) ++i;  // bytes: optimization_inputs
    if (text[i] == '\'' || text[i] == '"') {
      if (!string_at(&str)) return "unterminated string for '" + key + "'";
    } else if (text[i] == '[') {
      if (!list_at(&values)) return "malformed list for '" + key + "'";
    } else {
      char* end = nullptr;  // a number: icam_intrinsics
      values.push_back(std::strtod(text.c_str() + i, &end));
      if (end == text.c_str() + i) return "value of '" + key + "' is neither a string, a number nor a list";
      i = size_t(end - text.c_str());
    }
    if (key == "lensmodel") lensmodel = str, have_lensmodel = true;
    if (key == "intrinsics") intrinsics = values, have_intrinsics = true;
    if (key == "imagersize") imagersize = values, have_imagersize = true;
    skip();
    if (i < n && text[i] == ',') ++i;
  }
  if (!have_lensmodel) return "no 'lensmodel'";
  if (!have_intrinsics) return "no 'intrinsics'";
  if (!have_imagersize) return "no 'imagersize'";
  if (!is_mrcal_model(lensmodel)) return "lens model '" + lensmodel + "' is not one mrcal knows";
  const int count = intrinsics_count(lensmodel);
  if (int(intrinsics.size()) != count)
    return lensmodel + " takes " + std::to_string(count) + " intrinsics, the file has " +
           std::to_string(intrinsics.size());
  if (imagersize.size() != 2 || !(imagersize[0] > 0) || !(imagersize[1] > 0))
    return "'imagersize' is not two positive numbers";
  return "";
}

}  // namespace

int intrinsics_count(const std::string& lensmodel) { return parsed_lens_or_throw(lensmodel).model.param_count(); }

bool is_mrcal_model(const std::string& lensmodel) {
  const ParsedLens* p = parsed_lens(lensmodel);
  return p && p->model.is_mrcal();
}

std::optional<Pixel> project(const CameraModel& model, Vec3 d) {
  if (!std::isfinite(d.x) || !std::isfinite(d.y) || !std::isfinite(d.z)) return std::nullopt;
  const ParsedLens& pl = parsed_lens_or_throw(model.lensmodel);
  if (int(model.intrinsics.size()) != pl.model.param_count()) check_intrinsics(model);
  if (pl.model.type() == LensType::KannalaBrandt) return kb_project(model.intrinsics.data(), d);
  if (pl.model.type() == LensType::OmnidirMei) return mei_project(model.intrinsics.data(), d);
  const mrcal_lensmodel_t& lm = pl.mrcal;
  if (d.x == 0 && d.y == 0 && d.z == 0) return std::nullopt;
  const mrcal_lensmodel_metadata_t meta = mrcal_lensmodel_metadata(&lm);
  if (!meta.can_project_behind_camera && !(d.z > 0)) return std::nullopt;
  if (pl.model.info().family == LensFamily::Stereographic) {
    // The stereographic mapping sends the backward axis to infinity.
    if (d.x == 0 && d.y == 0 && d.z < 0) return std::nullopt;
  }
  mrcal_point3_t p;
  p.x = d.x;
  p.y = d.y;
  p.z = d.z;
  mrcal_point2_t q;
  if (!mrcal_project(&q, nullptr, nullptr, &p, 1, &lm, model.intrinsics.data())) return std::nullopt;
  if (!std::isfinite(q.x) || !std::isfinite(q.y)) return std::nullopt;
  return Pixel{q.x, q.y};
}

std::optional<Vec3> unproject(const CameraModel& model, Pixel pixel) {
  if (!std::isfinite(pixel.x) || !std::isfinite(pixel.y)) return std::nullopt;
  const ParsedLens& pl = parsed_lens_or_throw(model.lensmodel);
  if (int(model.intrinsics.size()) != pl.model.param_count()) check_intrinsics(model);
  if (pl.model.type() == LensType::KannalaBrandt) return kb_unproject(model.intrinsics.data(), pixel);
  if (pl.model.type() == LensType::OmnidirMei) return mei_unproject(model.intrinsics.data(), pixel);
  // plumb_bob (OpenCV4/5) by Newton, mrcal's answer within its own tolerance (1e-7 relative on
  // every number of the shared sets' reports). Not the rational model: its fold lies inside the
  // image often enough (the periphery of fisheye1's and Ladybug's fits) that two methods pick
  // different roots there, and its reports moved by up to 3 %.
  if (pl.model.type() == LensType::OpenCV4 || pl.model.type() == LensType::OpenCV5)
    if (const auto v = detail::opencv_unproject(model.intrinsics.data(), int(model.intrinsics.size()) - 4, pixel))
      return v;
  const mrcal_lensmodel_t& lm = pl.mrcal;
  mrcal_point2_t q;
  q.x = pixel.x;
  q.y = pixel.y;
  // NaN unless mrcal writes it: for some pixels of an OpenCV-model lens its iterative
  // unprojection returns success without writing the ray (valgrind: an uninitialised read),
  // which made two identical calibrations differ.
  mrcal_point3_t v;
  v.x = v.y = v.z = std::numeric_limits<double>::quiet_NaN();
  if (!mrcal_unproject(&v, &q, 1, &lm, model.intrinsics.data())) return std::nullopt;
  const Vec3 r{v.x, v.y, v.z};
  const double n = length(r);
  if (!(n > 0) || !std::isfinite(n)) return std::nullopt;
  return (1 / n) * r;
}

// ---- .cameramodel ---------------------------------------------------------------------

void write_cameramodel(const std::string& path, const CameraModel& model, const std::string& optimization_inputs) {
  if (!is_mrcal_model(model.lensmodel))
    throw InputError(path + ": mrcal has no lens model '" + model.lensmodel +
                     "'; write it as OpenCV YAML (.yaml) instead");
  const int n = intrinsics_count(model.lensmodel);
  if (int(model.intrinsics.size()) != n)
    throw InputError(path + ": " + model.lensmodel + " takes " + std::to_string(n) + " intrinsics, got " +
                     std::to_string(model.intrinsics.size()));
  check_model_file(path, model);
  // mrcal's C writer prints %f and its Python writer ~10 digits: write the text ourselves
  // with %.17g so doubles survive a round trip bit-exactly.
  std::string t;
  t += "# Camera model written by lightprobe (mrcal .cameramodel format)\n";
  t += "# rms_reprojection_px = " + g17(model.rms_reprojection_px) + "\n";
  t += "# cross_validation_px = " + g17(model.cross_validation_px) + "\n";
  t += "{\n";
  t += "    'lensmodel':  '" + model.lensmodel + "',\n\n";
  t += "    # intrinsics are fx,fy,cx,cy,distortion0,distortion1,....\n";
  t += "    'intrinsics': [";
  for (double v : model.intrinsics) {
    t += ' ';
    t += g17(v);
    t += ',';
  }
  t += "],\n\n";
  t += "    # extrinsics are rt_fromref\n";
  t += "    'extrinsics': [ 0, 0, 0, 0, 0, 0,],\n\n";
  t += "    'imagersize': [ " + std::to_string(model.width) + ", " + std::to_string(model.height) + ",],\n";
  if (!optimization_inputs.empty()) {
    // Base85 has no quote or backslash: the text goes between b'...' as it is.
    if (optimization_inputs.find_first_of("'\\\n") != std::string::npos)
      throw std::invalid_argument("write_cameramodel: optimization_inputs is not base85 text");
    t += "\n    'icam_intrinsics': 0,\n\n";
    t += "    # mrcal's optimization_inputs (mrcal.optimize's arguments at the optimum), as mrcal's Python\n";
    t += "    # writes them: a numpy .npz, base85. Changing the intrinsics invalidates them.\n";
    t += "    'optimization_inputs': b'" + optimization_inputs + "',\n";
  }
  t += "}\n";
  write_file_atomically(path, t);
}

CameraModel read_cameramodel(const std::string& path) {
  const std::string text = read_text(path);
  if (const std::string problem = precheck_cameramodel(text); !problem.empty())
    throw InputError(path + ": not a valid mrcal .cameramodel: " + problem);
  struct Free {
    void operator()(mrcal_cameramodel_t* m) const { mrcal_free_cameramodel(&m); }
  };
  // mrcal's parser reads a trailing comment up to a newline past the buffer's end (found by
  // fuzz_cameramodel): it gets the text with a newline closing it.
  const std::string closed = text + "\n";
  std::unique_ptr<mrcal_cameramodel_t, Free> cm(mrcal_read_cameramodel_string(closed.c_str(), int(closed.size())));
  if (!cm) throw InputError(path + ": not a valid mrcal .cameramodel");
  char name[1024];
  if (!mrcal_lensmodel_name(name, sizeof name, &cm->lensmodel))
    throw InputError(path + ": lens model name too long");
  CameraModel m;
  m.lensmodel = name;
  const int n = mrcal_lensmodel_num_params(&cm->lensmodel);
  m.intrinsics.assign(cm->intrinsics, cm->intrinsics + n);
  m.width = int(cm->imagersize[0]);
  m.height = int(cm->imagersize[1]);
  m.rms_reprojection_px = comment_value(text, "rms_reprojection_px");
  m.cross_validation_px = comment_value(text, "cross_validation_px");
  check_model_file(path, m);
  // What the file says that lightprobe does not apply is said, not dropped: mrcal's region
  // where the model is trusted (the unwrap uses the model beyond it too), and a rig camera's
  // pose (the probe's rotation is --rotation).
  for (const char* quote : {"'", "\""}) {
    const size_t key = text.find(std::string(quote) + "valid_intrinsics_region" + quote);
    if (key == std::string::npos) continue;
    const size_t open = text.find_first_not_of(" \t\r\n:", key + 25);
    if (open != std::string::npos && text[open] == '[' && text.find_first_not_of(" \t\r\n", open + 1) != std::string::npos &&
        text[text.find_first_not_of(" \t\r\n", open + 1)] != ']')
      warn(path + ": its valid_intrinsics_region is not applied: the model is used beyond it too, where mrcal calls it "
                  "unreliable");
  }
  bool posed = false;
  for (double v : cm->rt_cam_ref) posed |= v != 0;
  if (posed)
    warn(path + ": its extrinsics (a rig camera's pose) are not applied; give the probe's rotation with --rotation");
  return m;
}

// ---- OpenCV FileStorage YAML ----------------------------------------------------------

void write_opencv_yaml(const std::string& path, const CameraModel& model) {
  const std::string& lm = model.lensmodel;
  const std::vector<double>& p = model.intrinsics;
  const std::optional<LensModel> lens = LensModel::try_parse(lm);
  if (!lens || !lens->has_opencv_form())
    throw InputError(path + ": OpenCV has no form for lens model '" + lm +
                     "'; write it as mrcal .cameramodel instead");
  const LensTypeInfo& info = lens->info();
  const int n = lens->param_count();
  if (int(p.size()) != n)
    throw InputError(path + ": " + lm + " takes " + std::to_string(n) + " intrinsics, got " +
                     std::to_string(p.size()));
  check_model_file(path, model);
  // After the core (and Mei's xi) come the distortion coefficients; a zero-padded form
  // (pinhole as plumb_bob) writes zeros.
  std::vector<double> dist;
  if (info.opencv_zero_padded) dist.assign(size_t(info.opencv_coefficients), 0.0);
  else dist.assign(p.end() - info.opencv_coefficients, p.end());

  const int format = ends_with(path, ".xml") ? cv::FileStorage::FORMAT_XML : cv::FileStorage::FORMAT_YAML;
  cv::FileStorage fs(path, cv::FileStorage::WRITE | cv::FileStorage::MEMORY | format);
  fs << "image_width" << model.width << "image_height" << model.height;
  const cv::Mat K = (cv::Mat_<double>(3, 3) << p[0], 0, p[2], 0, p[1], p[3], 0, 0, 1);
  fs << "camera_matrix" << K;
  fs << "distortion_coefficients" << cv::Mat(cv::Mat_<double>(1, int(dist.size()), dist.data())).clone();
  fs << "distortion_model" << info.opencv_distortion_model;
  if (lens->is_mei()) fs << "xi" << p[4];
  fs << "lensmodel" << lm;
  fs << "rms_reprojection_px" << model.rms_reprojection_px;
  fs << "cross_validation_px" << model.cross_validation_px;
  write_file_atomically(path, fs.releaseAndGetString());
}

void read_yaml_matrix(const cv::FileNode& node, const std::string& path, const char* key, int max_values, cv::Mat* out) {
  if (node.isMap()) {
    const long long rows = int(node["rows"]), cols = int(node["cols"]);
    if (rows <= 0 || cols <= 0 || rows * cols > max_values)
      throw InputError(path + ": " + key + " claims " + std::to_string(rows) + "x" + std::to_string(cols) +
                       " values, at most " + std::to_string(max_values) + " expected");
  } else if (node.isSeq() && int(node.size()) > max_values) {
    throw InputError(path + ": " + key + " has " + std::to_string(node.size()) + " values, at most " +
                     std::to_string(max_values) + " expected");
  }
  try {
    node >> *out;
  } catch (const cv::Exception&) {
    throw InputError(path + ": " + key + " is not an OpenCV matrix");
  }
}

cv::FileStorage open_opencv_storage(const std::string& path) {
  const std::string text = read_text_file(path);
  // Only in the subsets calib/opencv_storage_check.h accepts, on which OpenCV 4.6 neither
  // aborts, crashes nor hangs; the extension says which (a .yaml holding XML is refused).
  if (lower_extension(path) == ".xml") {
    check_opencv_xml_text(path, text);
  } else {
    check_opencv_yaml_text(path, text);
  }
  try {
    cv::FileStorage fs(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    if (!fs.isOpened()) throw InputError(path + ": not an OpenCV FileStorage file");
    return fs;
  } catch (const cv::Exception& e) {
    throw InputError(path + ": not readable as OpenCV FileStorage (" + e.err + ")");
  }
}

CameraModel read_opencv_yaml(const std::string& path) {
  CameraModel m;
  try {
    cv::FileStorage fs = open_opencv_storage(path);
    auto need = [&](const char* key) {
      cv::FileNode node = fs[key];
      if (node.empty()) throw InputError(path + ": missing '" + key + "'");
      return node;
    };
    m.width = int(need("image_width"));
    m.height = int(need("image_height"));
    cv::Mat K, D;
    read_yaml_matrix(need("camera_matrix"), path, "camera_matrix", 9, &K);
    read_yaml_matrix(need("distortion_coefficients"), path, "distortion_coefficients", 14, &D);
    // Files written by OpenCV's own samples carry no distortion_model: a coefficient count
    // that only one model's form has (5: plumb_bob, 8: rational) names it; 4 stays
    // ambiguous (plumb_bob, fisheye, omnidir) and is refused.
    std::string dist_model;
    if (fs["distortion_model"].empty()) {
      const int n = int(D.total());
      const LensTypeInfo* only = nullptr;
      int matches = 0;
      for (const LensTypeInfo& t : lens_types())
        if (t.opencv_distortion_model && !t.opencv_zero_padded && t.opencv_coefficients == n) {
          only = &t;
          ++matches;
        }
      if (matches != 1)
        throw InputError(path + ": missing 'distortion_model' (needed with " + std::to_string(n) + " coefficients)");
      dist_model = only->opencv_distortion_model;
    } else {
      dist_model = std::string(fs["distortion_model"]);
    }
    if (K.rows != 3 || K.cols != 3) throw InputError(path + ": camera_matrix is not 3x3");
    K.convertTo(K, CV_64F);
    if (K.at<double>(0, 1) != 0)
      throw InputError(path + ": camera_matrix has skew " + g17(K.at<double>(0, 1)) + ", which no lens model here holds");
    // OpenCV's K is [fx 0 cx; 0 fy cy; 0 0 1]. A transposed one (MATLAB's IntrinsicMatrix) was
    // read with its centre at (0, 0), and a bottom row other than 0 0 1 was never looked at.
    if (K.at<double>(2, 0) != 0 || K.at<double>(2, 1) != 0 || K.at<double>(2, 2) != 1 || K.at<double>(1, 0) != 0)
      throw InputError(path + ": camera_matrix is not [fx 0 cx; 0 fy cy; 0 0 1] (bottom row " + g17(K.at<double>(2, 0)) +
                       " " + g17(K.at<double>(2, 1)) + " " + g17(K.at<double>(2, 2)) +
                       (K.at<double>(2, 0) != 0 || K.at<double>(2, 1) != 0 ? "; transposed, as MATLAB stores it?" : "") + ")");
    D.convertTo(D, CV_64F);
    D = D.reshape(1, 1);
    std::vector<double> dist(D.begin<double>(), D.end<double>());
    m.intrinsics = {K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2)};
    const int nd = int(dist.size());
    const std::optional<LensType> type = lens_type_from_opencv(dist_model, nd);
    if (!type) {
      std::string counts;
      for (const LensTypeInfo& t : lens_types())
        if (t.opencv_distortion_model && !t.opencv_zero_padded && dist_model == t.opencv_distortion_model)
          counts += (counts.empty() ? "" : " or ") + std::to_string(t.opencv_coefficients);
      if (counts.empty())
        throw InputError(path + ": distortion_model '" + dist_model + "' is not one of " +
                         opencv_distortion_model_names());
      throw InputError(path + ": distortion_model " + dist_model + " takes " + counts +
                       " distortion_coefficients, got " + std::to_string(nd));
    }
    const LensModel lens(*type);
    m.lensmodel = lens.name();
    if (lens.is_mei()) {
      cv::FileNode xi_node = need("xi");
      double xi;
      if (xi_node.isReal() || xi_node.isInt()) {
        xi = double(xi_node);
      } else {
        cv::Mat xm;
        read_yaml_matrix(xi_node, path, "xi", 1, &xm);
        if (xm.total() != 1) throw InputError(path + ": xi is not a single number");
        xm.convertTo(xm, CV_64F);
        xi = xm.at<double>(0);
      }
      m.intrinsics.push_back(xi);
    }
    m.intrinsics.insert(m.intrinsics.end(), dist.begin(), dist.end());
    // Our own writer records the exact model: one written in a zero-padded form (pinhole as
    // plumb_bob zeros) comes back as itself.
    cv::FileNode lm_node = fs["lensmodel"];
    if (lm_node.isString()) {
      const std::optional<LensModel> recorded = LensModel::try_parse(std::string(lm_node));
      if (recorded && recorded->info().opencv_zero_padded && dist_model == recorded->info().opencv_distortion_model &&
          nd == recorded->info().opencv_coefficients &&
          std::all_of(dist.begin(), dist.end(), [](double v) { return v == 0; })) {
        m.lensmodel = recorded->name();
        m.intrinsics.resize(size_t(recorded->param_count()));
      }
    }
    if (fs["rms_reprojection_px"].isReal()) m.rms_reprojection_px = double(fs["rms_reprojection_px"]);
    if (fs["cross_validation_px"].isReal()) m.cross_validation_px = double(fs["cross_validation_px"]);
  } catch (const cv::Exception& e) {
    throw InputError(path + ": not readable as OpenCV FileStorage (" + e.err + ")");
  }
  check_model_file(path, m);
  return m;
}

CameraModel read_camera_model(const std::string& path) {
  if (ends_with(path, ".cameramodel")) return read_cameramodel(path);
  if (ends_with(path, ".yaml") || ends_with(path, ".yml") || ends_with(path, ".xml")) return read_opencv_yaml(path);
  throw InputError(path + ": unknown camera model file type (expected .cameramodel, .yaml, .yml or .xml)");
}

}  // namespace lp
