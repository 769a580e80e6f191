#pragma once
// Plain SVG figures for the experiments' reports (no plotting library): a trajectory plot in the
// plane with equal axes, and a time-series plot. Axes carry ticks, labels and a legend.

#include <string>
#include <utility>
#include <vector>

namespace urs::lab {

struct Series {
  std::string label;
  std::string color;  // e.g. "#1f77b4"
  std::vector<std::pair<double, double>> points;
  bool dashed = false;
  bool markers = false;  // draw each point as a circle instead of a line
};

struct Figure {
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<Series> series;
  bool equal_axes = false;  // one metre is as long on both axes (trajectories)
};

// The figure as an SVG document, 520 px high and 720 px wide, wider when a legend label needs it.
std::string to_svg(const Figure& figure);

// Writes `text` to `path`; throws std::runtime_error naming the path on failure.
void write_text(const std::string& path, const std::string& text);

}  // namespace urs::lab
