#include "calib/colour_match.h"

#include <Eigen/Dense>
#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>
#include <sstream>

#include "core/error.h"
#include "core/file_io.h"
#include "core/image_io.h"
#include "core/json_file.h"

namespace lp {

ColourMatch fit_colour_match(const std::vector<ColourPatchPair>& pairs) {
  if (pairs.size() < 3) throw InputError(fmt::format("colour match needs at least 3 patches, got {}", pairs.size()));
  const int n = int(pairs.size());
  Eigen::MatrixXd P(n, 3), Q(n, 3);
  for (int i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      const double p = pairs[size_t(i)].probe[size_t(c)], q = pairs[size_t(i)].plate[size_t(c)];
      if (!std::isfinite(p) || !std::isfinite(q) || p < 0 || q < 0)
        throw InputError(fmt::format("colour patch {}: values must be finite and non-negative", i + 1));
      P(i, c) = p;
      Q(i, c) = q;
    }
  // Least squares Q = P M^T, solved column by column with a rank-revealing QR.
  const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(P);
  if (qr.rank() < 3) throw InputError("colour match: the probe colours of the patches do not span RGB (singular fit)");
  // Nearly grey patches pass the rank test and give entries of +-100 that fit noise: refused
  // when the probe colours' condition number says the fit amplifies a 0.1 % error past 100 %.
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(P);
  const Eigen::Vector3d sv = svd.singularValues();
  if (!(sv(2) > 1e-3 * sv(0)))
    throw InputError(fmt::format("colour match: the probe colours barely span RGB (condition number {:.0f}, nearly grey "
                                 "patches): the matrix would fit noise; add saturated patches",
                                 sv(2) > 0 ? sv(0) / sv(2) : INFINITY));
  const Eigen::MatrixXd Mt = qr.solve(Q);  // 3x3, = M^T
  ColourMatch m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.matrix.m[size_t(3 * r + c)] = Mt(c, r);
  double sq = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d e = Mt.transpose() * P.row(i).transpose() - Q.row(i).transpose();
    const double q = Q.row(i).norm();
    sq += q > 0 ? (e.squaredNorm() / (q * q)) : 0;
  }
  m.rms_relative = std::sqrt(sq / n);
  m.patches = n;
  return m;
}

std::vector<ColourPatchPair> read_colour_patches_csv(const std::string& path) {
  std::istringstream in(read_text_file(path));
  std::vector<ColourPatchPair> pairs;
  std::string line;
  int line_no = 0;
  bool first = true;
  // Where each of probe_r, probe_g, probe_b, plate_r, plate_g, plate_b is: the header's order
  // (it was skipped, and a plate-first file gave the inverse matrix), else this one.
  std::array<size_t, 6> column{0, 1, 2, 3, 4, 5};
  static const std::array<const char*, 6> kNames{"probe_r", "probe_g", "probe_b", "plate_r", "plate_g", "plate_b"};
  auto split = [](const std::string& text) {
    std::vector<std::string> fields;
    std::stringstream ss(text);
    std::string f;
    while (std::getline(ss, f, ',')) fields.push_back(trim_blanks(f));
    return fields;
  };
  while (std::getline(in, line)) {
    ++line_no;
    line = trim_blanks(line);
    if (line.empty() || line[0] == '#') continue;
    const std::vector<std::string> fields = split(line);
    if (first && !fields.empty() && !parse_decimal(fields[0])) {
      first = false;
      if (fields.size() != 6)
        throw InputError(fmt::format("{}:{}: the header must name 6 columns ({}), found '{}'", path, line_no,
                                     "probe_r,probe_g,probe_b,plate_r,plate_g,plate_b", line));
      std::array<bool, 6> seen{};
      for (size_t i = 0; i < 6; ++i) {
        std::string name = fields[i];
        std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return char(std::tolower(c)); });
        const auto it = std::find(kNames.begin(), kNames.end(), name);
        if (it == kNames.end() || seen[size_t(it - kNames.begin())])
          throw InputError(fmt::format("{}:{}: header column '{}' is not one of probe_r, probe_g, probe_b, plate_r, "
                                       "plate_g, plate_b (each once)",
                                       path, line_no, fields[i]));
        seen[size_t(it - kNames.begin())] = true;
        column[size_t(it - kNames.begin())] = i;
      }
      continue;
    }
    first = false;
    std::vector<double> v;
    for (const std::string& f : fields) {
      const std::optional<double> x = parse_decimal(f);
      if (!x) throw InputError(fmt::format("{}:{}: '{}' is not a number", path, line_no, f));
      v.push_back(*x);
    }
    if (v.size() != 6) throw InputError(fmt::format("{}:{}: expected 6 numbers, got {}", path, line_no, v.size()));
    ColourPatchPair p;
    for (int c = 0; c < 3; ++c) p.probe[size_t(c)] = v[column[size_t(c)]], p.plate[size_t(c)] = v[column[size_t(c) + 3]];
    for (double x : v)
      if (!std::isfinite(x) || x < 0)
        throw InputError(fmt::format("{}:{}: values must be finite and non-negative", path, line_no));
    pairs.push_back(p);
  }
  return pairs;
}

void save_colour_match(const std::string& path, const ColourMatch& match) {
  nlohmann::json j = {{"format", "lightprobe.colour_match/1"},
                      {"matrix", match.matrix.m},
                      {"rms_relative", match.rms_relative},
                      {"patches", match.patches}};
  write_file_atomically(path, j.dump(2) + "\n");
}

ColourMatch load_colour_match(const std::string& path) {
  const nlohmann::json j = read_json_file(path);
  check_json_format(j, path, "lightprobe.colour_match/1");
  try {
    ColourMatch m;
    const auto a = j.at("matrix").get<std::vector<double>>();
    if (a.size() != 9) throw InputError(path + ": matrix must have 9 numbers");
    for (size_t i = 0; i < 9; ++i) m.matrix.m[i] = a[i];
    m.rms_relative = j.value("rms_relative", 0.0);
    m.patches = j.value("patches", 0);
    return m;
  } catch (const nlohmann::json::exception& e) {
    throw InputError(json_field_problem(path, e));
  }
}

void apply_colour_match(EnvMap& map, const ColourMatch& match) {
  const auto& m = match.matrix;
  for (size_t i = 0; i < map.pixel_count(); ++i) {
    float* p = map.pixel(i);
    const Vec3 v = m * Vec3{p[0], p[1], p[2]};
    p[0] = float(std::max(0.0, v.x));
    p[1] = float(std::max(0.0, v.y));
    p[2] = float(std::max(0.0, v.z));
  }
}

}  // namespace lp
