// The stability map's report: DIR/stability.json, DIR/stability.md and the charts.
#pragma once

#include <string>
#include <vector>

#include "studies/stability.hpp"

namespace mpmrom {

// text with every character but letters and digits replaced by '_': a file name ("A1 15 samples" -> A1_15_samples).
std::string file_label(std::string text);

void write_stability_report(const StabilitySettings& settings, const std::vector<StabilityCase>& cases,
                            const Model& model, const std::string& scene_name);

}  // namespace mpmrom
