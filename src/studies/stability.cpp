// The stability map (stability.hpp): its study of the FOM and every reduced configuration over the time step with
// parameter extrapolation, the horizon, the sample points, the material and the load, each case against a reference.
#include "studies/stability.hpp"

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>

#include "analysis/evaluation.hpp"
#include "core/timing.hpp"
#include "fom/fom.hpp"
#include "io/atomic_file.hpp"
#include "mpmrom/snapshot.hpp"
#include "rom/kernels/projection.hpp"
#include "rom/outcome.hpp"
#include "snapshots/simulate.hpp"
#include "studies/detail/format.hpp"
#include "studies/detail/stability_report.hpp"
#include "studies/detail/study_runner.hpp"

namespace mpmrom {
namespace {

// A full-order run held in memory as a snapshot, up to the end or to the detector that stopped it.
struct FomRun {
  Snapshot frames;
  std::string cause, message;
  double stopped_at = -1;
  long steps = 0, safeguarded_steps = 0;
  double energy_ratio = 0;  // largest energy / budget at the output times
  double seconds = 0;
};

FomRun run_fom(const Scene& scene) {
  const auto start = SteadyClock::now();
  FomRun run;
  FomSolver solver(scene);
  Snapshot& s = run.frames;
  std::vector<real_t> X, mass, volume;
  solver.reference(X, mass, volume);
  s.num_points = solver.num_particles();
  s.X.assign(X.begin(), X.end());
  s.mass.assign(mass.begin(), mass.end());
  s.volume.assign(volume.begin(), volume.end());
  try {
    advance_through_outputs(solver, scene, [&](const ParticleFrame& f, double) {
      s.time.push_back(f.time);
      s.x.insert(s.x.end(), f.x.begin(), f.x.end());
      s.v.insert(s.v.end(), f.v.begin(), f.v.end());
      s.F.insert(s.F.end(), f.F.begin(), f.F.end());
      s.C.insert(s.C.end(), f.C.begin(), f.C.end());
      ++s.num_frames;
      if (solver.energy_budget() > 0)
        run.energy_ratio = std::max(run.energy_ratio, solver.energy().total() / solver.energy_budget());
    });
  } catch (const SimulationFailure& failure) {
    run.cause = to_string(failure.cause());
    run.message = failure.what();
    run.stopped_at = failure.time();
  }
  run.steps = solver.steps();
  run.safeguarded_steps = solver.safeguarded_steps();
  run.seconds = seconds_since(start);
  return run;
}

// Fills the case's errors from per-frame accumulators and classifies it.
void finish_case(StabilityCase& c, const std::vector<ErrorAccumulator>& frames, const std::vector<double>& times,
                 bool stopped, double threshold) {
  ErrorAccumulator all;
  for (std::size_t f = 0; f < frames.size(); ++f) {
    all.merge(frames[f]);
    c.times.push_back(times[f]);
    c.frame_position_errors.push_back(frames[f].metrics().position_error);
  }
  const ErrorMetrics metrics = all.metrics();
  c.position_error = metrics.position_error;
  c.displacement_error = metrics.displacement_error;
  c.final_position_error = c.frame_position_errors.empty() ? 0 : c.frame_position_errors.back();
  c.status = classify(stopped, c.position_error, threshold);
  if (c.status == "inaccurate") c.cause = "position error " + percent(c.position_error, "-") + " above the threshold";
}

// A reduced configuration of the map: its label in the report, algorithm and sample points (0: all).
struct RomConfig {
  std::string label;
  RomMethod method;
  int samples;
};

std::vector<RomConfig> rom_configs(int samples) {
  return {{"A1 " + std::to_string(samples) + " samples", RomMethod::MaterialPoint, samples},
          {"A1 all points", RomMethod::MaterialPoint, 0},
          {"A2 " + std::to_string(samples) + " samples", RomMethod::SampleNode, samples},
          {"A2 all points", RomMethod::SampleNode, 0}};
}

// The case runs this configuration.
void set_config(StabilityCase& c, const RomConfig& config) {
  c.method = to_string(config.method);
  c.samples = config.samples;
  c.config = config.label;
}

// The stability map's study: reduced configurations on the design's scene (StudyRunner), the training range to
// extrapolate from, scene variants written next to the report (so every case can be rerun by hand), full-order
// references cached by variant and parameters, and hyper-reductions cached by configuration.
class StabilityStudy {
 public:
  StabilityStudy(const StabilitySettings& settings, const std::function<void(const StabilityCase&)>& on_case)
      : settings_(settings),
        on_case_(on_case),
        runner_(settings.scene_path, settings.selection),
        model_(load_model(settings.model_path)) {
    const Scene& base = runner_.scene();
    if (base.design.names.empty())
      throw std::runtime_error(settings.scene_path + " has no [design]: nothing to extrapolate from");
    const std::size_t num_names = base.design.names.size();
    const auto runs = base.design.all_runs();
    lo_.assign(num_names, 1e300);
    hi_.assign(num_names, -1e300);
    for (std::size_t r = 0; r < runs.size(); ++r) {
      const auto& test = base.design.test_runs;
      if (std::find(test.begin(), test.end(), int(r)) != test.end()) continue;
      for (std::size_t k = 0; k < num_names; ++k) {
        lo_[k] = std::min(lo_[k], runs[r][k]);
        hi_[k] = std::max(hi_[k], runs[r][k]);
      }
    }
    std::filesystem::create_directories(std::filesystem::path(settings.out_dir) / "scenes");
    if (settings.selection == SampleSelection::Greedy && !settings.data_dir.empty())
      data_ = load_training_data({settings.data_dir});
  }

  const Scene& scene() const { return runner_.scene(); }
  const std::vector<StabilityCase>& cases() const { return cases_; }
  const Model& model() const { return model_; }

  std::vector<double> values_at(double extrapolation, double load_factor = 1) const {
    std::vector<double> v(lo_.size());
    for (std::size_t k = 0; k < lo_.size(); ++k) v[k] = lo_[k] + (hi_[k] - lo_[k]) * (1.0 + extrapolation);
    v[0] *= load_factor;
    return v;
  }

  // A variant of the scene (overrides of its entries) as a file in DIR/scenes/, named by its label.
  std::string variant(const std::string& label, const std::vector<std::string>& overrides) {
    const auto path = std::filesystem::path(settings_.out_dir) / "scenes" / (label + ".toml");
    if (!written_.count(path.string())) {
      write_file_atomically(path.string(), override_scene(runner_.scene(), overrides).source_text);
      written_.insert(path.string());
    }
    return path.string();
  }

  std::vector<std::string> horizon_overrides(double horizon) const {
    const Scene& base = runner_.scene();
    // left a double: the scene parser checks the count (a whole number in range) before converting it
    const double outputs = std::round(base.num_outputs * horizon);
    return {"time.end_time=" + general(base.end_time * outputs / base.num_outputs, 17),
            "time.outputs=" + general(outputs, 17)};
  }

  // config's settings at cfl (0: the scene's).
  RomSettings rom_settings(const RomConfig& config, double cfl) const {
    return runner_.rom_settings(config.method, config.samples, cfl);
  }

  const FomRun& reference(const std::string& scene_path, const std::vector<double>& values) {
    std::string key = scene_path;
    for (const double v : values) key += " " + general(v, 17);
    auto it = references_.find(key);
    if (it == references_.end())
      it = references_.emplace(key, run_fom(scene_for_run(scene_path, runner_.names(), values))).first;
    return it->second;
  }

  const HyperReduction& reduction(RomMethod method, int samples) {
    const auto key = std::make_pair(int(method), samples);
    auto it = reductions_.find(key);
    if (it == reductions_.end()) {
      const RomSettings rom = runner_.rom_settings(method, samples, 0);
      it = reductions_.emplace(key, runner_.hyper_reduction(model_, rom, data_ ? &*data_ : nullptr)).first;
    }
    return it->second;
  }

  void fom_case(StabilityCase c, const std::string& scene_path, const std::string& reference_path) {
    const FomRun& ref = reference(reference_path, c.values);
    const FomRun run = run_fom(scene_for_run(scene_path, runner_.names(), c.values));
    c.seconds = run.seconds;
    c.details = {
        {"steps", run.steps}, {"safeguarded_steps", run.safeguarded_steps}, {"energy_over_budget", run.energy_ratio}};
    if (!run.cause.empty()) {
      c.cause = run.cause + ": " + run.message;
      c.stopped_at = run.stopped_at;
    }
    record(c, ref,
           run.frames.num_frames == 0 ? std::vector<ErrorAccumulator>{}
                                      : resolution_errors_by_frame(ref.frames, run.frames),
           !run.cause.empty());
  }

  void rom_case(StabilityCase c, const std::string& scene_path, const RomSettings& rom) {
    const FomRun& ref = reference(scene_path, c.values);
    const auto start = SteadyClock::now();
    const RomResult result =
        runner_.rollouts(model_, scene_path, {{c.values, ""}}, rom, reduction(rom.method, rom.samples));
    c.seconds = seconds_since(start);
    const RolloutOutcome& o = result.outcomes[0];
    c.details = {{"steps", result.steps}};
    // the safeguards' counters and the warning, named as in the ROM file
    impl::for_each_outcome_field([&](const auto& field) {
      if (!field.detector) c.details[field.name] = o.*field.member;
    });
    const bool stopped = (o.flags & rom::fatal_flags) != 0;
    if (stopped) {
      c.cause = impl::describe_flags(o.flags & rom::fatal_flags);
      c.stopped_at = o.stopped_at;
    }
    const std::size_t r = std::size_t(model_.latent_dim);
    const std::size_t frames = std::min<std::size_t>(std::size_t(o.frames_completed), ref.frames.num_frames);
    const std::vector<double> xhat(result.xhat.begin(), result.xhat.begin() + frames * r);
    const std::vector<double> xhatdot(result.xhatdot.begin(), result.xhatdot.begin() + frames * r);
    record(c, ref, rollout_errors_by_frame(model_, ref.frames, xhat, xhatdot), stopped);
  }

  // On one scene variant: the FOM at CFL 1 (its error against the reference at the scene's cfl is the
  // time-integration error alone), then every ROM configuration at the scene's cfl.
  void fom_and_roms(StabilityCase c, const std::string& path, const std::string& fom_path) {
    c.method = "fom";
    c.config = "FOM cfl 1.0";
    c.cfl = 1.0;
    fom_case(c, fom_path, path);
    for (const auto& config : rom_configs(settings_.samples)) {
      set_config(c, config);
      c.cfl = runner_.scene().cfl;
      rom_case(c, path, rom_settings(config, 0));
    }
  }

 private:
  void record(StabilityCase& c, const FomRun& ref, const std::vector<ErrorAccumulator>& frames, bool stopped) {
    if (!ref.cause.empty()) {
      c.status = "no reference";
      c.cause = "the full-order reference failed: " + ref.message;
      c.position_error = c.displacement_error = c.final_position_error = std::nan("");
    } else {
      finish_case(c, frames, ref.frames.time, stopped, settings_.threshold);
    }
    cases_.push_back(c);
    if (on_case_) on_case_(c);
  }

  const StabilitySettings& settings_;
  std::function<void(const StabilityCase&)> on_case_;
  StudyRunner runner_;
  Model model_;
  std::optional<TrainingData> data_;
  std::vector<double> lo_, hi_;
  std::set<std::string> written_;
  std::map<std::string, FomRun> references_;
  std::map<std::pair<int, int>, HyperReduction> reductions_;
  std::vector<StabilityCase> cases_;
};

// Time step x extrapolation: the FOM at every cfl (and, past the safeguard's, with it), every reduced configuration
// at every cfl, at each distance beyond the training range.
void time_step_study(StabilityStudy& study, const StabilitySettings& settings, const std::string& scene_path) {
  for (const double d : settings.extrapolation) {
    const std::vector<double> values = study.values_at(d);
    for (const bool guarded : {false, true})
      for (const double cfl : settings.fom_cfl) {
        if (guarded && cfl <= settings.fom_max_cfl) continue;  // the safeguard changes nothing there
        StabilityCase c;
        c.study = "time_step";
        c.method = "fom";
        c.config = guarded ? "FOM max_cfl " + general(settings.fom_max_cfl) : "FOM";
        c.cfl = cfl;
        c.extrapolation = d;
        c.values = values;
        std::vector<std::string> overrides{"time.cfl=" + general(cfl, 17)};
        if (guarded) overrides.push_back("time.max_cfl=" + general(settings.fom_max_cfl, 17));
        study.fom_case(c, study.variant(file_label(c.config + " cfl " + general(cfl)), overrides), scene_path);
      }
    for (const auto& config : rom_configs(settings.samples))
      for (const double cfl : settings.rom_cfl) {
        StabilityCase c;
        c.study = "time_step";
        set_config(c, config);
        c.cfl = cfl;
        c.extrapolation = d;
        c.values = values;
        study.rom_case(c, scene_path, study.rom_settings(config, cfl));
      }
  }
}

// Horizon, at the scene's time step.
void horizon_study(StabilityStudy& study, const StabilitySettings& settings, const std::vector<double>& centre) {
  for (const double horizon : settings.horizons) {
    const std::string path = study.variant("horizon_" + general(horizon), study.horizon_overrides(horizon));
    StabilityCase c;
    c.study = "horizon";
    c.horizon = horizon;
    c.values = centre;
    auto at_limit = study.horizon_overrides(horizon);
    at_limit.push_back("time.cfl=1");
    study.fom_and_roms(c, path, study.variant("horizon_" + general(horizon) + "_cfl_1", at_limit));
  }
}

// Sample points, from r / 3 (under-determined: fewer equations than unknowns) to all.
void samples_study(StabilityStudy& study, const std::string& scene_path, const std::vector<double>& centre) {
  const int r = study.model().latent_dim;
  std::vector<int> counts{std::max(1, r / 3), r, 2 * r, 5 * r, 15, 50, 0};
  std::sort(counts.begin(), counts.end() - 1);
  counts.erase(std::unique(counts.begin(), counts.end() - 1), counts.end() - 1);
  for (const RomMethod method : {RomMethod::MaterialPoint, RomMethod::SampleNode})
    for (const int count : counts) {
      StabilityCase c;
      c.study = "samples";
      c.method = to_string(method);
      c.samples = count;
      c.config = std::string(method == RomMethod::MaterialPoint ? "A1 " : "A2 ") +
                 (count > 0 ? std::to_string(count) + " samples" : "all points");
      c.cfl = study.scene().cfl;
      c.values = centre;
      study.rom_case(c, scene_path, study.rom_settings({c.config, method, count}, 0));
    }
}

// Material: nearly incompressible and stiffer than training.
void material_study(StabilityStudy& study, const StabilitySettings& settings, const std::vector<double>& centre) {
  std::vector<std::pair<std::string, std::string>> materials;
  for (const double nu : settings.poisson_ratios)
    materials.push_back({"nu " + general(nu), "material.poisson_ratio=" + general(nu, 17)});
  materials.push_back(
      {"E x" + general(settings.stiffer),
       "material.youngs_modulus=" + general(study.scene().material.youngs_modulus * settings.stiffer, 17)});
  for (const auto& [label, override_text] : materials) {
    const std::string path = study.variant(file_label("material " + label), {override_text});
    StabilityCase c;
    c.study = "material";
    c.material = label;
    c.values = centre;
    study.fom_and_roms(c, path,
                       study.variant(file_label("material " + label + " cfl 1"), {override_text, "time.cfl=1"}));
  }
}

// Load: the first design parameter scaled up, for Algorithm 2's inversion under large deformation.
void load_study(StabilityStudy& study, const StabilitySettings& settings, const std::string& scene_path) {
  for (const double factor : settings.load_factors)
    for (const auto& config : rom_configs(settings.samples)) {
      if (config.method != RomMethod::SampleNode) continue;
      StabilityCase c;
      c.study = "load";
      set_config(c, config);
      c.cfl = study.scene().cfl;
      c.load_factor = factor;
      c.values = study.values_at(-0.5, factor);
      study.rom_case(c, scene_path, study.rom_settings(config, 0));
    }
}

}  // namespace

std::string classify(bool stopped, double position_error, double threshold) {
  if (stopped) return "unstable";
  return position_error > threshold || !std::isfinite(position_error) ? "inaccurate" : "stable";
}

std::vector<StabilityCase> run_stability(const StabilitySettings& settings,
                                         const std::function<void(const StabilityCase&)>& on_case) {
  StabilityStudy study(settings, on_case);
  const std::string scene_path = study.variant("scene", {});
  time_step_study(study, settings, scene_path);
  const std::vector<double> centre = study.values_at(-0.5);
  horizon_study(study, settings, centre);
  samples_study(study, scene_path, centre);
  material_study(study, settings, centre);
  load_study(study, settings, scene_path);
  write_stability_report(settings, study.cases(), study.model(), study.scene().name);
  return study.cases();
}

}  // namespace mpmrom
