// How a rollout relates to the model's training: the fastest training motion in the latent space, and the parameters
// that lie outside the training runs' range.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "mpmrom/rom.hpp"

namespace mpmrom {

double training_latent_speed(const Model& model) {
  const int r = model.latent_dim;
  std::map<std::int64_t, std::vector<int>> run_codes;
  for (std::size_t c = 0; c < model.num_codes(); ++c) run_codes[model.code_run[c]].push_back(int(c));
  double fastest = 0;
  for (auto& [run, codes] : run_codes) {
    std::sort(codes.begin(), codes.end(), [&](int a, int b) { return model.code_time[a] < model.code_time[b]; });
    for (std::size_t k = 0; k + 1 < codes.size(); ++k) {
      const double dt = model.code_time[codes[k + 1]] - model.code_time[codes[k]];
      if (!(dt > 0)) continue;
      double step2 = 0;
      for (int q = 0; q < r; ++q) {
        const double d = model.codes[std::size_t(codes[k + 1]) * r + q] - model.codes[std::size_t(codes[k]) * r + q];
        step2 += d * d;
      }
      fastest = std::max(fastest, std::sqrt(step2) / dt);
    }
  }
  return fastest;
}

std::vector<std::string> training_range_warnings(const Model& model, const std::vector<std::string>& names,
                                                 const std::vector<RolloutCase>& cases) {
  std::vector<std::string> warnings(cases.size());
  if (model.scene_text.empty()) return warnings;
  Scene trained;
  try {
    trained = parse_scene(model.scene_text, "the model's scene");
  } catch (const std::exception&) {
    return warnings;  // a model from another version of the scene format: no range to compare with
  }
  const ParameterDesign& design = trained.design;
  const auto runs = design.all_runs();
  // the training runs' range of each named parameter (lo > hi: not a parameter of the design)
  std::vector<double> lo(names.size(), std::numeric_limits<double>::infinity()), hi(names.size(), -lo[0]);
  for (std::size_t i = 0; i < names.size(); ++i) {
    const auto it = std::find(design.names.begin(), design.names.end(), names[i]);
    if (it == design.names.end()) continue;
    const std::size_t column = std::size_t(it - design.names.begin());
    for (std::size_t run = 0; run < runs.size(); ++run) {
      if (std::find(design.test_runs.begin(), design.test_runs.end(), int(run)) != design.test_runs.end()) continue;
      lo[i] = std::min(lo[i], runs[run][column]);
      hi[i] = std::max(hi[i], runs[run][column]);
    }
  }
  for (std::size_t c = 0; c < cases.size(); ++c) {
    const std::vector<double>& values = cases[c].values;
    std::string warning;
    for (std::size_t i = 0; i < names.size() && i < values.size(); ++i) {
      if (!(lo[i] <= hi[i]) || (values[i] >= lo[i] && values[i] <= hi[i])) continue;
      const double beyond = values[i] < lo[i] ? lo[i] - values[i] : values[i] - hi[i];
      std::ostringstream line;
      line << (warning.empty() ? "" : "; ") << names[i] << " = " << values[i] << " lies outside the training range ["
           << lo[i] << ", " << hi[i] << "]";
      if (hi[i] > lo[i]) line << " by " << std::lround(100 * beyond / (hi[i] - lo[i])) << " % of its width";
      warning += line.str();
    }
    warnings[c] = warning.empty() ? warning : warning + " (extrapolation: expect larger errors)";
  }
  return warnings;
}

std::string training_range_warning(const Model& model, const std::vector<std::string>& names,
                                   const std::vector<double>& values) {
  return training_range_warnings(model, names, {RolloutCase{values, ""}}).front();
}

}  // namespace mpmrom
