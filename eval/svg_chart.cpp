#include "eval/svg_chart.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <utility>
#include <vector>

namespace lp {

namespace {

constexpr const char* kColours[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2"};
constexpr int kPanelW = 460, kPanelH = 320, kLeft = 70, kRight = 20, kTop = 36, kBottom = 50;

std::string escape(const std::string& s) {
  std::string r;
  for (char c : s) {
    if (c == '<') r += "&lt;";
    else if (c == '>') r += "&gt;";
    else if (c == '&') r += "&amp;";
    else r += c;
  }
  return r;
}

// Decade range covering [lo, hi] on a log axis.
void decades(double lo, double hi, double* a, double* b) {
  *a = std::floor(std::log10(lo));
  *b = std::ceil(std::log10(hi));
  if (*b <= *a) *b = *a + 1;
}

// A log (decades) or linear ("nice" steps) axis over the data's range.
struct Axis {
  bool log = true;
  double lo = 0, hi = 1;
  std::vector<std::pair<double, std::string>> ticks;
  double unit(double v) const {
    return log ? (std::log10(v) - lo) / (hi - lo) : (v - lo) / (hi - lo);
  }
};

std::string tick_label(double e);

Axis make_axis(const std::vector<double>& values, bool log) {
  Axis a;
  a.log = log;
  const auto [mn, mx] = std::minmax_element(values.begin(), values.end());
  if (log) {
    decades(*mn, *mx, &a.lo, &a.hi);
    for (double e = a.lo; e <= a.hi + 1e-9; e += 1) a.ticks.emplace_back(std::pow(10.0, e), tick_label(e));
    return a;
  }
  double lo = *mn, hi = *mx;
  if (hi - lo < 1e-12 * std::max(1.0, std::fabs(hi))) lo -= 0.5, hi += 0.5;
  const double raw = (hi - lo) / 5, mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double step = raw / mag < 1.5 ? mag : raw / mag < 3.5 ? 2 * mag : raw / mag < 7.5 ? 5 * mag : 10 * mag;
  a.lo = std::floor(lo / step) * step;
  a.hi = std::ceil(hi / step) * step;
  for (double v = a.lo; v <= a.hi + step * 1e-6; v += step) a.ticks.emplace_back(v, fmt::format("{:g}", std::fabs(v) < step * 1e-6 ? 0.0 : v));
  return a;
}

std::string tick_label(double e) {
  const double v = std::pow(10.0, e);
  if (e >= 0 && e < 4) return fmt::format("{:g}", v);
  if (e < 0 && e > -4) return fmt::format("{:g}", v);
  return fmt::format("1e{:g}", e);
}

}  // namespace

std::string svg_chart(const std::string& title, const std::vector<ChartPanel>& panels, int columns) {
  columns = std::max(1, std::min(columns, int(panels.size())));
  const int rows = int((panels.size() + size_t(columns) - 1) / size_t(columns));
  // At least 920 px wide, so that a one-panel chart still has room for its title and legend.
  const int panel_w = std::max(kPanelW, 920 / columns);
  const int width = columns * panel_w;
  std::map<std::string, const char*> colour;
  for (const auto& p : panels)
    for (const auto& s : p.series)
      if (!colour.count(s.name)) colour[s.name] = kColours[colour.size() % std::size(kColours)];

  // One legend for the whole chart, under the title, so it never hides a curve; it wraps
  // into as many rows as it needs.
  std::string legend;
  int legend_rows = 1;
  {
    int x = 20, y = 36;
    for (const auto& [name, c] : colour) {
      const int item = 14 + 7 * int(name.size()) + 24;
      if (x + item > width - 10 && x > 20) x = 20, y += 18, ++legend_rows;
      legend += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"10\" height=\"10\" fill=\"{}\"/>"
                         "<text x=\"{}\" y=\"{}\">{}</text>\n",
                         x, y, c, x + 14, y + 9, escape(name));
      x += item;
    }
  }
  const int top = 44 + 18 * legend_rows;
  const int height = top + rows * kPanelH + 30;
  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{}\" height=\"{}\" font-family=\"sans-serif\" "
      "font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
      "<text x=\"{}\" y=\"24\" text-anchor=\"middle\" font-size=\"16\">{}</text>\n",
      width, height, width / 2, escape(title));
  svg += legend;
  for (size_t pi = 0; pi < panels.size(); ++pi) {
    const ChartPanel& p = panels[pi];
    const int ox = int(pi % size_t(columns)) * panel_w, oy = top + int(pi / size_t(columns)) * kPanelH;
    auto usable = [&](double x, double y) {
      return std::isfinite(x) && std::isfinite(y) && (!p.log_x || x > 0) && (!p.log_y || y > 0);
    };
    std::vector<double> xs, ys;
    for (const auto& s : p.series)
      for (size_t i = 0; i < s.x.size(); ++i)
        if (usable(s.x[i], s.y[i])) xs.push_back(s.x[i]), ys.push_back(s.y[i]);
    if (xs.empty()) continue;
    const Axis ax = make_axis(xs, p.log_x), ay = make_axis(ys, p.log_y);
    const double pw = panel_w - kLeft - kRight, ph = kPanelH - kTop - kBottom;
    auto X = [&](double v) { return ox + kLeft + ax.unit(v) * pw; };
    auto Y = [&](double v) { return oy + kTop + (1 - ay.unit(v)) * ph; };
    svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\" font-size=\"13\">{}</text>\n",
                       ox + kLeft + pw / 2, oy + kTop - 10, escape(p.title));
    svg += fmt::format("<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"#333\"/>\n",
                       ox + kLeft, oy + kTop, pw, ph);
    for (const auto& [v, label] : ax.ticks) {
      const double x = X(v);
      svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1}\" x2=\"{0:.1f}\" y2=\"{2}\" stroke=\"#ddd\"/>"
                         "<text x=\"{0:.1f}\" y=\"{3}\" text-anchor=\"middle\">{4}</text>\n",
                         x, oy + kTop, oy + kTop + ph, oy + kTop + ph + 16, label);
    }
    for (const auto& [v, label] : ay.ticks) {
      const double y = Y(v);
      svg += fmt::format("<line x1=\"{0}\" y1=\"{1:.1f}\" x2=\"{2}\" y2=\"{1:.1f}\" stroke=\"#ddd\"/>"
                         "<text x=\"{3}\" y=\"{4:.1f}\" text-anchor=\"end\">{5}</text>\n",
                         ox + kLeft, y, ox + kLeft + pw, ox + kLeft - 6, y + 4, label);
    }
    svg += fmt::format("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", ox + kLeft + pw / 2,
                       oy + kTop + ph + 36, escape(p.x_label));
    svg += fmt::format("<text transform=\"translate({},{}) rotate(-90)\" text-anchor=\"middle\">{}</text>\n",
                       ox + 18, oy + kTop + ph / 2, escape(p.y_label));
    for (const auto& s : p.series) {
      std::string pts;
      for (size_t i = 0; i < s.x.size(); ++i)
        if (usable(s.x[i], s.y[i])) pts += fmt::format("{:.1f},{:.1f} ", X(s.x[i]), Y(s.y[i]));
      if (pts.empty()) continue;
      const char* c = colour[s.name];
      if (s.lines)
        svg += fmt::format("<polyline points=\"{}\" fill=\"none\" stroke=\"{}\" stroke-width=\"1.8\"/>\n", pts, c);
      for (size_t i = 0; i < s.x.size(); ++i) {
        if (!usable(s.x[i], s.y[i])) continue;
        svg += fmt::format("<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"2.8\" fill=\"{}\"/>", X(s.x[i]), Y(s.y[i]), c);
        if (i < s.labels.size() && (!s.lines || i == 0 || i + 1 == s.x.size()))
          svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"9\" fill=\"{}\">{}</text>", X(s.x[i]) + 4,
                             Y(s.y[i]) - 4, c, escape(s.labels[i]));
      }
      svg += "\n";
    }
  }
  svg += "</svg>\n";
  return svg;
}

}  // namespace lp
