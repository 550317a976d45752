// Numbers as the studies' reports and charts print them: one home for the pipeline, the stability map and charts.
#pragma once

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

namespace mpmrom {

// value with `digits` digits after the point ("%.*f").
inline std::string fixed(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, value);
  return text;
}

// value to `digits` significant digits ("%.*g"); 17 reads back as the same double.
inline std::string general(double value, int digits = 3) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*g", digits, value);
  return text;
}

// 100 * fraction to three significant digits and " %"; `not_finite` where there is no such number (the pipeline
// writes "failed" for a failed configuration, the stability map "-" for a missing error).
inline std::string percent(double fraction, const char* not_finite) {
  if (!std::isfinite(fraction)) return not_finite;
  return general(100 * fraction, 3) + " %";
}

// A reduced method's name in a report or a chart's legend, from its command-line name ("point", "node", "galerkin").
inline std::string method_title(const std::string& method) {
  if (method == "point") return "Algorithm 1";
  if (method == "node") return "Algorithm 2";
  if (method == "galerkin") return "Galerkin step";
  return method;
}

// A figure of a report: its number, or infinity where there is none (a failed configuration's null).
inline double number(const nlohmann::json& value) {
  return value.is_number() ? value.get<double>() : std::numeric_limits<double>::infinity();
}

}  // namespace mpmrom
