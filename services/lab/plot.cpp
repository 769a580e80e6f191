#include "plot.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace urs::lab {

namespace {

constexpr double kPlotWidth = 490;  // the frame; the figure is 720 px wide unless the legend needs more
constexpr double kHeight = 520;
constexpr double kLeft = 70;
constexpr double kRight = 160;    // room for the legend, at least
constexpr double kCharWidth = 7;  // a generous estimate of one character at 12 px sans-serif
constexpr double kTop = 40;
constexpr double kBottom = 55;

std::string escaped(const std::string& text) {
  std::string out;
  for (char c : text) {
    if (c == '&')
      out += "&amp;";
    else if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else
      out += c;
  }
  return out;
}

std::string number(double value, int decimals = 2) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(decimals) << value;
  std::string text = out.str();
  if (text.find('.') != std::string::npos) {
    text.erase(text.find_last_not_of('0') + 1);
    if (text.back() == '.') text.pop_back();
  }
  return text == "-0" ? "0" : text;
}

// A step of 1, 2 or 5 times a power of ten giving about `count` ticks over `span`.
double tick_step(double span, int count) {
  const double raw = span / count;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * power >= raw) return m * power;
  }
  return 10 * power;
}

}  // namespace

std::string to_svg(const Figure& figure) {
  double x0 = std::numeric_limits<double>::max(), x1 = std::numeric_limits<double>::lowest();
  double y0 = x0, y1 = x1;
  for (const auto& series : figure.series) {
    for (const auto& [x, y] : series.points) {
      x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
    }
  }
  if (x0 > x1) x0 = 0, x1 = 1, y0 = 0, y1 = 1;
  if (x1 - x0 < 1e-9) x0 -= 0.5, x1 += 0.5;
  if (y1 - y0 < 1e-9) y0 -= 0.5, y1 += 0.5;
  const double pad_x = (x1 - x0) * 0.06, pad_y = (y1 - y0) * 0.08;
  x0 -= pad_x, x1 += pad_x, y0 -= pad_y, y1 += pad_y;
  // The legend's column is as wide as its longest label (swatch 28 px, margins 14 + 10 px).
  std::size_t longest = 0;
  for (const auto& series : figure.series) longest = std::max(longest, series.label.size());
  const double right = std::max(kRight, 14 + 28 + kCharWidth * static_cast<double>(longest) + 10);
  const double width = kLeft + kPlotWidth + right;
  const double plot_w = kPlotWidth, plot_h = kHeight - kTop - kBottom;
  double sx = plot_w / (x1 - x0), sy = plot_h / (y1 - y0);
  if (figure.equal_axes) {  // one scale for both axes, the range grown to fill the frame
    const double s = std::min(sx, sy);
    const double cx = (x0 + x1) / 2, cy = (y0 + y1) / 2;
    sx = sy = s;
    x0 = cx - plot_w / s / 2, x1 = cx + plot_w / s / 2, y0 = cy - plot_h / s / 2, y1 = cy + plot_h / s / 2;
  }
  auto px = [&](double x) { return kLeft + (x - x0) * sx; };
  auto py = [&](double y) { return kTop + plot_h - (y - y0) * sy; };

  std::ostringstream svg;
  svg << "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" << width << "\" height=\"" << kHeight
      << "\" viewBox=\"0 0 " << width << " " << kHeight << "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  svg << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  svg << "<text x=\"" << width / 2 << "\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">" << escaped(figure.title)
      << "</text>\n";
  // Grid and ticks.
  const double step_x = tick_step(x1 - x0, 8), step_y = tick_step(y1 - y0, 6);
  for (double x = std::ceil(x0 / step_x) * step_x; x <= x1 + 1e-9; x += step_x) {
    svg << "<line x1=\"" << px(x) << "\" y1=\"" << kTop << "\" x2=\"" << px(x) << "\" y2=\"" << kTop + plot_h
        << "\" stroke=\"#e4e4e4\"/>\n<text x=\"" << px(x) << "\" y=\"" << kTop + plot_h + 16
        << "\" text-anchor=\"middle\">" << number(x) << "</text>\n";
  }
  for (double y = std::ceil(y0 / step_y) * step_y; y <= y1 + 1e-9; y += step_y) {
    svg << "<line x1=\"" << kLeft << "\" y1=\"" << py(y) << "\" x2=\"" << kLeft + plot_w << "\" y2=\"" << py(y)
        << "\" stroke=\"#e4e4e4\"/>\n<text x=\"" << kLeft - 6 << "\" y=\"" << py(y) + 4 << "\" text-anchor=\"end\">"
        << number(y) << "</text>\n";
  }
  svg << "<rect x=\"" << kLeft << "\" y=\"" << kTop << "\" width=\"" << plot_w << "\" height=\"" << plot_h
      << "\" fill=\"none\" stroke=\"#333\"/>\n";
  svg << "<text x=\"" << kLeft + plot_w / 2 << "\" y=\"" << kHeight - 14 << "\" text-anchor=\"middle\">"
      << escaped(figure.x_label) << "</text>\n";
  svg << "<text transform=\"translate(18," << kTop + plot_h / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
      << escaped(figure.y_label) << "</text>\n";
  // Series, clipped to the frame.
  svg << "<clipPath id=\"frame\"><rect x=\"" << kLeft << "\" y=\"" << kTop << "\" width=\"" << plot_w << "\" height=\""
      << plot_h << "\"/></clipPath>\n<g clip-path=\"url(#frame)\">\n";
  for (const auto& series : figure.series) {
    if (series.markers) {
      for (const auto& [x, y] : series.points) {
        svg << "<circle cx=\"" << px(x) << "\" cy=\"" << py(y) << "\" r=\"5\" fill=\"none\" stroke=\"" << series.color
            << "\" stroke-width=\"2\"/>\n";
      }
      continue;
    }
    svg << "<polyline fill=\"none\" stroke=\"" << series.color << "\" stroke-width=\"1.6\""
        << (series.dashed ? " stroke-dasharray=\"6 4\"" : "") << " points=\"";
    for (const auto& [x, y] : series.points) svg << number(px(x), 1) << "," << number(py(y), 1) << " ";
    svg << "\"/>\n";
  }
  svg << "</g>\n";
  // Legend.
  double ly = kTop + 10;
  for (const auto& series : figure.series) {
    const double lx = kLeft + plot_w + 14;
    if (series.markers) {
      svg << "<circle cx=\"" << lx + 10 << "\" cy=\"" << ly << "\" r=\"5\" fill=\"none\" stroke=\"" << series.color
          << "\" stroke-width=\"2\"/>\n";
    } else {
      svg << "<line x1=\"" << lx << "\" y1=\"" << ly << "\" x2=\"" << lx + 22 << "\" y2=\"" << ly << "\" stroke=\""
          << series.color << "\" stroke-width=\"2\"" << (series.dashed ? " stroke-dasharray=\"6 4\"" : "") << "/>\n";
    }
    svg << "<text x=\"" << lx + 28 << "\" y=\"" << ly + 4 << "\">" << escaped(series.label) << "</text>\n";
    ly += 20;
  }
  svg << "</svg>\n";
  return svg.str();
}

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  if (!out) throw std::runtime_error("cannot write " + path);
}

}  // namespace urs::lab
