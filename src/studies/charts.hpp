// Charts for reports, drawn by gnuplot: each chart is a self-contained gnuplot script (its data inline) written next
// to the images, so a reader can restyle it and draw it again with `gnuplot NAME.gp`.
#pragma once

#include <string>
#include <vector>

namespace mpmrom {

struct ChartSeries {
  std::string title;
  std::vector<double> x, y;
  std::string style = "points";     // a gnuplot style: points, linespoints, lines, steps
  std::vector<std::string> labels;  // optional: one text label per point, drawn beside it
  std::vector<double> color;        // optional: one value per point, drawn through the chart's colour scale
};

struct Chart {
  std::string title, x_label, y_label;
  bool log_x = false, log_y = false;
  std::string color_label;  // the colour scale's title, for series with color values
  bool log_color = false;
  std::vector<ChartSeries> series;
};

// Writes DIR/NAME.gp and, with gnuplot on the PATH, DIR/NAME.png and DIR/NAME.svg (each atomically). Returns an
// empty string, or one line saying why no images were drawn (the script is written either way).
std::string write_chart(const std::string& dir, const std::string& name, const Chart& chart);

}  // namespace mpmrom
