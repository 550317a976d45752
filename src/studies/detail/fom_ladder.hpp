// The pipeline's comparison of the two models: the FOM's resolution ladder on the test runs and the ROM's Pareto
// front of cost against error set against it.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "studies/detail/pipeline_study.hpp"

namespace mpmrom {

// The FOM's resolution ladder on the test runs: every level against the reference, with its cost. Fills references
// with the reference runs, in the order of the test runs.
nlohmann::json fom_ladder(const PipelineSettings& settings, const PipelineStudy& study,
                          std::vector<Snapshot>& references);

// The ROM's Pareto front against the FOM ladder: for each front point, the best FOM error at equal or lower cost.
nlohmann::json compare_fronts(const nlohmann::json& ladder, const std::vector<nlohmann::json>& configurations,
                              const std::string& metric);

}  // namespace mpmrom
