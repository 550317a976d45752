// The reduced model's settings: the method and selection names, their checks and JSON, and the summary of a
// hyper-reduction.
#include <cmath>
#include <stdexcept>
#include <string>

#include "mpmrom/rom.hpp"

namespace mpmrom {

RomMethod rom_method_from_string(const std::string& name) {
  if (name == "point") return RomMethod::MaterialPoint;
  if (name == "node") return RomMethod::SampleNode;
  if (name == "galerkin") return RomMethod::Galerkin;
  throw std::invalid_argument("method must be 'point' (Algorithm 1), 'node' (Algorithm 2) or 'galerkin', not '" + name +
                              "'");
}

std::string to_string(RomMethod method) {
  switch (method) {
    case RomMethod::MaterialPoint: return "point";
    case RomMethod::SampleNode: return "node";
    case RomMethod::Galerkin: return "galerkin";
  }
  return "";
}

SampleSelection sample_selection_from_string(const std::string& name) {
  if (name == "region") return SampleSelection::Region;
  if (name == "random") return SampleSelection::Random;
  if (name == "greedy") return SampleSelection::Greedy;
  if (name == "cubature") return SampleSelection::Cubature;
  if (name == "greedy-projection") return SampleSelection::GreedyProjection;
  throw std::invalid_argument(
      "selection must be 'greedy-projection', 'greedy', 'cubature', 'region' or 'random', not '" + name + "'");
}

std::string to_string(SampleSelection selection) {
  switch (selection) {
    case SampleSelection::Region: return "region";
    case SampleSelection::Random: return "random";
    case SampleSelection::Greedy: return "greedy";
    case SampleSelection::Cubature: return "cubature";
    case SampleSelection::GreedyProjection: return "greedy-projection";
  }
  return "";
}

ProjectionScheme projection_scheme_from_string(const std::string& name) {
  if (name == "velocity") return ProjectionScheme::Velocity;
  if (name == "position") return ProjectionScheme::Position;
  throw std::invalid_argument("projection must be 'velocity' or 'position', not '" + name + "'");
}

std::string to_string(ProjectionScheme scheme) {
  return scheme == ProjectionScheme::Velocity ? "velocity" : "position";
}

SampleWeighting sample_weighting_from_string(const std::string& name) {
  if (name == "mass") return SampleWeighting::Mass;
  if (name == "cubature") return SampleWeighting::Cubature;
  if (name == "auto") return SampleWeighting::Auto;
  throw std::invalid_argument("weights must be 'mass', 'cubature' or 'auto', not '" + name + "'");
}

SnapshotSource snapshot_source_from_string(const std::string& name) {
  if (name == "reduced") return SnapshotSource::Reduced;
  if (name == "states") return SnapshotSource::States;
  if (name == "full") return SnapshotSource::Full;
  throw std::invalid_argument("cubature snapshots must be 'reduced', 'states' or 'full', not '" + name + "'");
}

std::string to_string(SnapshotSource source) {
  return source == SnapshotSource::Reduced ? "reduced" : source == SnapshotSource::States ? "states" : "full";
}

CubatureTarget cubature_target_from_string(const std::string& name) {
  if (name == "own") return CubatureTarget::Own;
  if (name == "grid") return CubatureTarget::Grid;
  throw std::invalid_argument("cubature target must be 'own' or 'grid', not '" + name + "'");
}

std::string to_string(CubatureTarget target) { return target == CubatureTarget::Own ? "own" : "grid"; }

GalerkinStrain galerkin_strain_from_string(const std::string& name) {
  if (name == "continuum") return GalerkinStrain::Continuum;
  if (name == "grid") return GalerkinStrain::Grid;
  throw std::invalid_argument("Galerkin strain must be 'continuum' or 'grid', not '" + name + "'");
}

std::string to_string(GalerkinStrain strain) { return strain == GalerkinStrain::Continuum ? "continuum" : "grid"; }

TimeIntegrator time_integrator_from_string(const std::string& name) {
  if (name == "euler") return TimeIntegrator::SymplecticEuler;
  if (name == "leapfrog") return TimeIntegrator::Leapfrog;
  throw std::invalid_argument("integrator must be 'euler' or 'leapfrog', not '" + name + "'");
}

std::string to_string(TimeIntegrator integrator) {
  return integrator == TimeIntegrator::SymplecticEuler ? "euler" : "leapfrog";
}

std::string to_string(SampleWeighting weighting) {
  return weighting == SampleWeighting::Mass ? "mass" : weighting == SampleWeighting::Cubature ? "cubature" : "auto";
}

RomSettings rom_defaults(RomMethod method) {
  RomSettings settings;
  settings.method = method;
  if (method == RomMethod::SampleNode) {
    // Algorithm 2's samples fitted to its own step from the training states, one set: on the poke cylinder 15
    // samples give 0.335 % / 8.44 % against 0.608 % / 15.5 % with Algorithm 1's set (docs/rom.md "Defaults"), in
    // 34 s of set-up, where rolling out trial sets would take tens of minutes.
    settings.snapshot_source = SnapshotSource::States;
    settings.selection_sensitivities = {0};
  }
  if (method == RomMethod::Galerkin) {
    settings.selection = SampleSelection::Cubature;
    settings.snapshot_source = SnapshotSource::States;
    settings.cubature_target = CubatureTarget::Grid;
    settings.galerkin_strain = GalerkinStrain::Grid;
    settings.integrator = TimeIntegrator::Leapfrog;
  }
  return settings;
}

SampleWeighting fitted_weights(const RomSettings& settings) {
  if (settings.weighting != SampleWeighting::Auto) return settings.weighting;
  const bool fits =
      settings.selection == SampleSelection::GreedyProjection || settings.selection == SampleSelection::Cubature;
  return fits && settings.samples > 0 ? SampleWeighting::Cubature : SampleWeighting::Mass;
}

nlohmann::json RomSettings::to_json() const {
  return {{"method", to_string(method)},
          {"samples", samples},
          {"selection", to_string(selection)},
          {"selection_sensitivities", selection_sensitivities},
          {"seed", seed},
          {"cfl", cfl},
          {"envelope_margin", envelope_margin},
          {"quadrature_order", quadrature_order},
          {"newton_tolerance", newton_tolerance},
          {"newton_iterations", newton_iterations},
          {"projection_iterations", projection_iterations},
          {"projection", to_string(projection)},
          {"rate_damping", rate_damping},
          {"weights", to_string(fitted_weights(*this))},
          {"cubature_snapshots", to_string(snapshot_source)},
          {"cubature_candidates", cubature_candidates},
          {"cubature_runs", cubature_runs},
          {"cubature_frames", cubature_frames},
          {"cubature_target", to_string(cubature_target)},
          {"galerkin_strain", to_string(galerkin_strain)},
          {"galerkin_transfer", galerkin_transfer},
          {"galerkin_node_average", galerkin_node_average},
          {"integrator", to_string(integrator)},
          {"max_condition", max_condition},
          {"regularization", regularization},
          {"regularize", regularize},
          {"inversion_fallback", inversion_fallback},
          {"max_failed_inversions", max_failed_inversions},
          {"energy_growth", energy_growth},
          {"end_time", end_time}};
}

void RomSettings::validate() const {
  if (samples < 0) throw std::invalid_argument("--samples must be >= 0 (0: all points)");
  // Above 1 lies beyond the explicit FOM's limit; the reduced dynamics (r degrees of freedom) may still be stable. The
  // grid methods' transfers and co-moving node sets follow the grid's CFL number; the Galerkin step's time step is
  // bounded by its reduced dynamics' highest frequency (stable_step.hpp), so that --cfl only caps it.
  const double max_cfl = method == RomMethod::Galerkin ? 100 : 10;
  if (cfl < 0 || cfl > max_cfl)
    throw std::invalid_argument("--cfl must be in (0, " + std::to_string(int(max_cfl)) + "] (0: the scene's)" +
                                (method == RomMethod::Galerkin ? "" : "; up to 100 with --method galerkin"));
  if (!(envelope_margin >= 0) || envelope_margin > 4) throw std::invalid_argument("--margin must be in [0, 4] cells");
  if (quadrature_order < 1 || quadrature_order > 3) throw std::invalid_argument("--quadrature must be 1, 2 or 3");
  if (!(newton_tolerance > 0)) throw std::invalid_argument("--newton-tolerance must be positive");
  if (projection_iterations < 0 || projection_iterations > 10)
    throw std::invalid_argument("--projection-iterations must be in [0, 10]");
  if (!(rate_damping >= 0) || rate_damping > 1e6) throw std::invalid_argument("--rate-damping must be in [0, 1e6]");
  if (selection_sensitivities.empty() || selection_sensitivities.size() > 8)
    throw std::invalid_argument("--selection-sensitivities takes 1 to 8 weights");
  for (const double w : selection_sensitivities)
    if (!(w >= 0) || w > 1e3) throw std::invalid_argument("--selection-sensitivities must be in [0, 1000]");
  if (method == RomMethod::Galerkin && projection == ProjectionScheme::Position)
    throw std::invalid_argument("--method galerkin takes --projection velocity");
  if (cubature_candidates < 16 || cubature_candidates > 65536)
    throw std::invalid_argument("--cubature-candidates must be in [16, 65536]");
  if (cubature_runs < 1 || cubature_runs > 4096 || cubature_frames < 1 || cubature_frames > 4096)
    throw std::invalid_argument("--cubature-runs and --cubature-frames must be in [1, 4096]");
  if (cubature_target == CubatureTarget::Grid && method != RomMethod::Galerkin)
    throw std::invalid_argument("--cubature-target grid is for --method galerkin (the grid methods fit the grid step)");
  if (cubature_target == CubatureTarget::Grid && snapshot_source == SnapshotSource::Full)
    throw std::invalid_argument("--cubature-target grid takes --cubature-snapshots reduced or states");
  if (galerkin_strain == GalerkinStrain::Grid && method != RomMethod::Galerkin)
    throw std::invalid_argument("--galerkin-strain grid is for --method galerkin");
  if (galerkin_transfer && galerkin_strain != GalerkinStrain::Grid)
    throw std::invalid_argument(
        "--galerkin-transfer needs --galerkin-strain grid (it carries momentum through its nodes)");
  if (galerkin_node_average && galerkin_strain != GalerkinStrain::Grid)
    throw std::invalid_argument("--galerkin-node-average needs --galerkin-strain grid (it weighs the grid's nodes)");
  if (integrator == TimeIntegrator::Leapfrog && method != RomMethod::Galerkin)
    throw std::invalid_argument(
        "--integrator leapfrog is for --method galerkin (the grid methods step as the grid does)");
  if (integrator == TimeIntegrator::Leapfrog && galerkin_transfer)
    throw std::invalid_argument("--integrator leapfrog does not take --galerkin-transfer (its gather is at one state)");
  if (newton_iterations < 1) throw std::invalid_argument("--newton-iterations must be >= 1");
  if (max_condition < 0 || regularization < 0)
    throw std::invalid_argument("--max-condition and --regularization must be >= 0");
  if (!(max_failed_inversions >= 0 && max_failed_inversions <= 1))
    throw std::invalid_argument("--max-failed-inversions must be a fraction in [0, 1]");
  if (!(energy_growth >= 0) || !std::isfinite(energy_growth))
    throw std::invalid_argument("--energy-growth must be >= 0 (0: no check)");
  if (!(end_time >= 0) || !std::isfinite(end_time))
    throw std::invalid_argument("--end-time must be >= 0 (0: the scene's)");
}

nlohmann::json HyperReduction::summary() const {
  return {{"samples", samples.size()},
          {"source_points", source_points.size()},
          {"neighbours", source_points.empty() ? 0 : source_points.size() - samples.size()},
          {"quadrature_points", quadrature_weight.size()},
          {"nodes", nodes.size()},
          {"node_source_pairs", node_sources.size()},
          {"weight_misfits", weight_misfits},
          {"weight_misfits_held_out", weight_misfits_held_out},
          {"stable_time_step", stable_time_step}};
}

}  // namespace mpmrom
