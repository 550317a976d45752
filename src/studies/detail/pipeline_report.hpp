// The pipeline's report beside report.json: report.md (pipeline_report.cpp) and its charts (pipeline_charts.cpp).
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace mpmrom {

// report.md from report.json's content; chart_problems: why charts were not drawn, listed at its end.
std::string pipeline_markdown(const nlohmann::json& report, const std::vector<std::string>& chart_problems);

// Draws the report's charts into dir; returns the problems (one line each, none when every chart was drawn).
std::vector<std::string> draw_pipeline_charts(const std::string& dir, const nlohmann::json& report);

}  // namespace mpmrom
