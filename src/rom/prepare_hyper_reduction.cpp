// What a rollout's settings ask of the hyper-reduction, in one place for the CLI, the studies and the deployment API:
// the samples, their precomputed sets and their weights (docs/rom.md "Sample selection", "Sample weights").
#include <cstdio>
#include <stdexcept>
#include <string>
#include <vector>

#include "core/timing.hpp"
#include "mpmrom/rom.hpp"
#include "rom/detail/selection_trials.hpp"
#include "rom/detail/snapshots.hpp"
#include "rom/detail/stable_step.hpp"

namespace mpmrom {
namespace {

std::string misfit_list(const std::vector<double>& misfits) {
  std::string text;
  for (const double misfit : misfits) {
    char number[32];
    std::snprintf(number, sizeof number, " %.3g", misfit);
    text += number;
  }
  return text;
}

// The settings the stored set is fitted with (store_projection_samples, default_projection_selector).
RomSettings stored_set_settings() {
  RomSettings settings;
  settings.selection = SampleSelection::GreedyProjection;
  settings.snapshot_source = SnapshotSource::Reduced;
  return settings;
}

// Whether a and b take the same all-point reduced step, the motion the greedy projection fits its set to.
bool same_projection_step(const RomSettings& a, const RomSettings& b, const Scene& scene) {
  const auto cfl = [&scene](const RomSettings& s) { return s.cfl > 0 ? s.cfl : scene.cfl; };
  return cfl(a) == cfl(b) && a.projection_iterations == b.projection_iterations && a.projection == b.projection &&
         a.rate_damping == b.rate_damping;
}

// The model's stored greedy projection set, when it is the one settings ask for: its count, fitted to the same step
// (a set fitted at one time step can be a poor one at another: docs/results/rom/README.md).
bool stored_set_applies(const Model& model, const Scene& scene, const RomSettings& settings) {
  return settings.selection == SampleSelection::GreedyProjection && settings.method == stored_set_settings().method &&
         settings.snapshot_source == SnapshotSource::Reduced && settings.samples > 0 &&
         model.projection_samples.size() == std::size_t(settings.samples) &&
         model.projection_sensitivities == settings.selection_sensitivities &&
         same_projection_step(settings, stored_set_settings(), scene);
}

// What the offline fits fit, for the log line before them (at 10^6 points they take minutes).
std::string fitted_snapshots(const RomSettings& settings, const TrainingData* data) {
  if (data != nullptr && settings.snapshot_source == SnapshotSource::Full) return "the full-order training runs";
  const std::string runs = "up to " + std::to_string(settings.cubature_runs) + " training runs";
  if (settings.snapshot_source == SnapshotSource::States)
    return "one all-point sub-step from each training state, " + runs + " x " +
           std::to_string(settings.cubature_frames) + " frames";
  return "the all-point reduced model rolled out over " + runs;
}

// The samples and (where the selection fits them) weights of the selections that choose both together.
CubatureFit joint_selection(const Model& model, const Scene& scene, const RomSettings& settings,
                            const TrainingData* data, const std::function<void(const std::string&)>& log,
                            const SelectorSource& selector) {
  CubatureFit selected;
  if (settings.samples <= 0) return selected;
  const auto say = [&log](const std::string& line) {
    if (log) log(line);
  };
  const bool fit = fitted_weights(settings) == SampleWeighting::Cubature;
  if (settings.selection == SampleSelection::GreedyProjection && settings.method == RomMethod::Galerkin)
    throw std::invalid_argument(
        "--method galerkin needs another --selection (cubature, its default, greedy, region or random): "
        "greedy-projection fits the grid step of --method point and node");
  if (stored_set_applies(model, scene, settings)) {
    for (std::size_t k = 0; k < model.projection_samples.size(); ++k) {
      const auto p = std::size_t(model.projection_samples[k]);
      selected.samples.push_back(int(p));
      selected.weights.push_back(fit ? model.projection_weights[k] : model.mass[p]);
    }
    say("greedy projection: the model's stored set of " + std::to_string(settings.samples) + " samples" +
        (fit ? " with its fitted weights" : ", mass weights"));
  } else if (settings.selection == SampleSelection::GreedyProjection) {
    say("greedy projection: fitting " + std::to_string(settings.samples) +
        " samples to the all-point reduced model's sub-steps (" + to_string(settings.snapshot_source) +
        " snapshots; `mpmrom train --scene` stores a set of " + std::to_string(RomSettings{}.samples) +
        " with the model, for the default time step and projection)");
    selected = selector ? impl::tried_projection_set(model, scene, settings, selector(settings), fit, log)
                        : impl::tried_projection_set(
                              model, scene, settings,
                              ProjectionSelector(model, cubature_snapshots(scene, settings, data)), fit, log);
    say("greedy projection: relative error" + misfit_list(selected.misfits) +
        " (the samples' projection of the velocity increments against every point's; masses" +
        (fit ? ", then fitted weights)" : ")"));
  } else if (settings.selection == SampleSelection::Cubature) {
    say("cubature: choosing " + std::to_string(settings.samples) + " samples and their weights, fitted to " +
        fitted_snapshots(settings, data) + "...");
    selected = cubature_selection(model, cubature_snapshots(scene, settings, data), std::size_t(settings.samples));
  }
  return selected;
}

// The samples, their sets and weights, without the Galerkin step's time-step bound.
HyperReduction fitted_reduction(const Model& model, const Scene& scene, const RomSettings& settings,
                                const TrainingData* data, const std::function<void(const std::string&)>& log,
                                const SelectorSource& selector) {
  const CubatureFit selected = joint_selection(model, scene, settings, data, log, selector);
  const auto samples = selected.samples.empty() ? select_samples(model, scene, settings, data) : selected.samples;
  HyperReduction reduction = build_hyper_reduction(model, scene, settings, samples);
  if (fitted_weights(settings) != SampleWeighting::Cubature) return reduction;
  if (!selected.samples.empty() && settings.selection != SampleSelection::Cubature) {
    reduction.weights = selected.weights;  // the greedy projection fitted them to its own error
    return reduction;
  }
  if (log && selected.samples.empty())
    log("cubature weights: fitting the samples' weights to " + fitted_snapshots(settings, data) + "...");
  const CubatureFit fit =
      selected.samples.empty() ? cubature_weights(model, cubature_snapshots(scene, settings, data), samples) : selected;
  reduction.weights = fit.weights;
  reduction.force_weights = fit.force_weights;
  reduction.weight_misfits = fit.misfits;
  reduction.weight_misfits_held_out = fit.held_out_misfits;
  if (log)
    log("cubature weights: relative misfit" + misfit_list(fit.misfits) +
        " (the normal matrix, then each projected field)" +
        (fit.held_out_misfits.empty()
             ? ""
             : "; over a training run held out of the same fit" + misfit_list(fit.held_out_misfits)));
  return reduction;
}

}  // namespace

HyperReduction prepare_hyper_reduction(const Model& model, const Scene& scene, const RomSettings& settings,
                                       const TrainingData* data, const std::function<void(const std::string&)>& log,
                                       const SelectorSource& selector) {
  const auto start = SteadyClock::now();
  HyperReduction reduction = fitted_reduction(model, scene, settings, data, log, selector);
  if (log && settings.samples > 0) {
    char line[64];
    std::snprintf(line, sizeof line, "samples and weights: %.1f s", seconds_since(start));
    log(line);
  }
  if (settings.method != RomMethod::Galerkin) return reduction;
  // Symplectic Euler is stable below 2 / omega; half of it leaves room for states between the training states.
  const auto bound_start = SteadyClock::now();
  if (log)
    log("reduced dynamics: probing its highest frequency at up to " + std::to_string(impl::max_state_frames) +
        " frames of up to " + std::to_string(impl::stable_step_runs) + " training runs, " +
        std::to_string(2 * model.latent_dim + 1) + " sub-steps each...");
  const double omega = impl::reduced_highest_frequency(model, scene, settings, reduction);
  if (omega > 0) reduction.stable_time_step = 1 / omega;
  if (log) {
    char line[200];
    std::snprintf(line, sizeof line,
                  "reduced dynamics: highest frequency %.4g rad/s over the training states, time step at most %.4g s "
                  "(%.1f s)",
                  omega, reduction.stable_time_step, seconds_since(bound_start));
    log(line);
  }
  return reduction;
}

ProjectionSelector default_projection_selector(const Model& model, const Scene& scene) {
  return ProjectionSelector(model, cubature_snapshots(scene, stored_set_settings(), nullptr));
}

void store_projection_samples(Model& model, const Scene& scene, const ProjectionSelector& selector, std::size_t count,
                              const std::function<void(const std::string&)>& log) {
  RomSettings settings = stored_set_settings();
  settings.samples = int(count);
  const CubatureFit fit = impl::tried_projection_set(model, scene, settings, selector, true, log);
  model.projection_samples.assign(fit.samples.begin(), fit.samples.end());
  model.projection_weights = fit.weights;
  model.projection_sensitivities = settings.selection_sensitivities;
  if (log)
    log("greedy projection: stored " + std::to_string(fit.samples.size()) + " samples, relative error" +
        misfit_list(fit.misfits) + " (masses, then fitted weights)");
}

}  // namespace mpmrom
