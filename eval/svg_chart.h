// Minimal SVG line charts on log or linear axes: speed against accuracy, one curve per method.
// Written by hand (a few dozen lines) so that charts need no plotting stack at run time.
#pragma once

#include <string>
#include <vector>

namespace lp {

struct ChartSeries {
  std::string name;
  std::vector<double> x, y;           // positive values (log axes); others are skipped
  std::vector<std::string> labels;    // optional, one per point (e.g. the light count)
  bool lines = true;                  // false: points only (a scatter), every point labelled
};

struct ChartPanel {
  std::string title, x_label, y_label;
  std::vector<ChartSeries> series;
  bool log_x = true, log_y = true;  // log axes show decades; linear ones "nice" steps
};

// Panels in a grid of `columns`; series with the same name share a colour across panels.
std::string svg_chart(const std::string& title, const std::vector<ChartPanel>& panels, int columns = 2);

}  // namespace lp
