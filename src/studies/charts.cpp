// Charts as self-contained gnuplot scripts, and their images where gnuplot is installed.
#include "studies/charts.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

#include "io/atomic_file.hpp"
#include "studies/detail/format.hpp"

namespace mpmrom {
namespace {

std::string quoted(const std::string& text) {
  std::string out = "\"";
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string script(const Chart& chart, const std::string& terminal, const std::string& output) {
  std::ostringstream gp;
  gp << "set terminal " << terminal << "\nset output " << quoted(output) << "\n";
  gp << "set title " << quoted(chart.title) << "\nset xlabel " << quoted(chart.x_label) << "\nset ylabel "
     << quoted(chart.y_label) << "\n";
  if (chart.log_x) gp << "set logscale x\n";
  if (chart.log_y) gp << "set logscale y\n";
  if (!chart.color_label.empty()) gp << "set cblabel " << quoted(chart.color_label) << "\nset palette rgb 33,13,10\n";
  if (chart.log_color) gp << "set logscale cb\n";
  // noenhanced: names like position_error are text, not subscripts
  gp << "set termoption noenhanced\nset grid\nset key below\nset pointsize 1.2\n";
  for (std::size_t s = 0; s < chart.series.size(); ++s) {
    const auto& series = chart.series[s];
    gp << "$s" << s << " << EOD\n";
    for (std::size_t i = 0; i < series.x.size(); ++i) {
      // points that a logarithmic axis cannot show (zero or negative) are left out rather than breaking the plot
      if ((chart.log_x && !(series.x[i] > 0)) || (chart.log_y && !(series.y[i] > 0))) continue;
      if (!std::isfinite(series.x[i]) || !std::isfinite(series.y[i])) continue;
      if (i < series.color.size() && !(std::isfinite(series.color[i]) && (!chart.log_color || series.color[i] > 0)))
        continue;
      gp << general(series.x[i], 9) << " " << general(series.y[i], 9) << " "
         << quoted(i < series.labels.size() ? series.labels[i] : "");
      if (!series.color.empty()) gp << " " << general(series.color[i], 9);
      gp << "\n";
    }
    gp << "EOD\n";
  }
  gp << "plot ";
  for (std::size_t s = 0; s < chart.series.size(); ++s) {
    const auto& series = chart.series[s];
    if (s) gp << ", \\\n     ";
    // gnuplot wants the line style before any option that refines it (pt, ps): "points pt 5" -> "points ls 1 pt 5"
    const std::size_t space = series.style.find(' ');
    const std::string kind = series.style.substr(0, space);
    const std::string options = space == std::string::npos ? "" : series.style.substr(space);
    if (series.color.empty())
      gp << "$s" << s << " using 1:2 with " << kind << " linestyle " << s + 1 << options;
    else
      gp << "$s" << s << " using 1:2:4 with " << kind << options << " lc palette";
    gp << " title " << quoted(series.title);
    if (!series.labels.empty()) gp << ", $s" << s << " using 1:2:3 with labels offset 0.8,0.6 left font \",8\" notitle";
  }
  gp << "\n";
  return gp.str();
}

}  // namespace

std::string write_chart(const std::string& dir, const std::string& name, const Chart& chart) {
  const std::filesystem::path base = std::filesystem::path(dir) / name;
  // the script kept beside the images draws the PNG; the SVG comes from the same text with another terminal
  const std::string png_script = script(chart, "pngcairo size 1000,640 font \"sans,11\"", name + ".png");
  const std::string svg_script = script(chart, "svg size 1000,640 dynamic font \"sans,11\"", name + ".svg");
  write_file_atomically(base.string() + ".gp", png_script);
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) return "gnuplot is not installed: no images drawn";
  for (const auto& [text, extension] :
       {std::pair{png_script, std::string(".png")}, std::pair{svg_script, std::string(".svg")}}) {
    // gnuplot writes into a temporary directory; the image is renamed into place once it is whole
    const std::filesystem::path work = base.string() + extension + ".tmp.d";
    std::filesystem::create_directories(work);
    write_file_atomically((work / "chart.gp").string(), text);
    const std::string command = "cd " + quoted(work.string()) + " && gnuplot chart.gp 2> gnuplot.log";
    const int status = std::system(command.c_str());
    const std::filesystem::path image = work / (name + extension);
    std::error_code error;
    if (status != 0 || !std::filesystem::exists(image)) {
      std::filesystem::remove_all(work, error);
      return "gnuplot failed to draw " + name + extension;
    }
    std::filesystem::rename(image, base.string() + extension, error);
    std::filesystem::remove_all(work, error);
    if (error) return "cannot move " + name + extension + " into " + dir + ": " + error.message();
  }
  return "";
}

}  // namespace mpmrom
