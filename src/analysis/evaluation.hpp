// Errors of reduced rollouts against full-order reference runs (SPEC.md metrics): each rollout is matched to the
// reference run with the same parameter values and decoded at the reference's material points and output times.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "snapshots/metrics.hpp"
#include "mpmrom/model.hpp"
#include "rom/rom_file.hpp"
#include "mpmrom/training_data.hpp"

namespace mpmrom {

// Errors of one rollout (latent states xhat, xhatdot: (frames, r)) against the first frames of one reference run
// (the same output times; a rollout may be shorter than its reference).
ErrorAccumulator rollout_errors(const Model& model, const Snapshot& reference, const std::vector<double>& xhat,
                                const std::vector<double>& xhatdot);

// Errors of a full-order run against a reference run of the same scene and parameters at another resolution (other
// material points, the same output times). Each reference point q takes the run's material point p nearest to it in
// the reference configuration and its first-order expansion there: x = x_p + F_p (X_q - X_p),
// v = v_p + C_p F_p (X_q - X_p) (C: APIC's velocity gradient), F = F_p; exact for affine motion, O(h^2) otherwise.
ErrorAccumulator resolution_errors(const Snapshot& reference, const Snapshot& run);

// The same two comparisons frame by frame (one accumulator per frame of the rollout or run, which may be shorter
// than its reference): how the error grows over time.
std::vector<ErrorAccumulator> rollout_errors_by_frame(const Model& model, const Snapshot& reference,
                                                      const std::vector<double>& xhat,
                                                      const std::vector<double>& xhatdot);
std::vector<ErrorAccumulator> resolution_errors_by_frame(const Snapshot& reference, const Snapshot& run);

// The whole evaluation as SPEC's JSON: aggregate metrics over all matched rollouts under the metric names, "train"
// and "test" aggregates, and one entry per rollout under "runs". Throws std::runtime_error when no rollout matches a
// reference, or a matched reference has other output times or points.
nlohmann::json evaluate_rom(const RomFile& rom, const Model& model, const TrainingData& references);

}  // namespace mpmrom
