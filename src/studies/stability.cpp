#include "studies/stability.hpp"

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include "io/atomic_file.hpp"
#include "core/benchmark_record.hpp"
#include "studies/charts.hpp"
#include "analysis/evaluation.hpp"
#include "fom/fom.hpp"
#include "rom/outcome.hpp"
#include "rom/kernels/projection.hpp"
#include "mpmrom/snapshot.hpp"

namespace mpmrom {
namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

std::string number(double value, int digits = 3) {
  char text[32];
  std::snprintf(text, sizeof text, "%.*g", digits, value);
  return text;
}

std::string percent(double fraction) {
  return std::isfinite(fraction) ? number(100 * fraction) + " %" : "-";
}

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
  const auto start = Clock::now();
  FomRun run;
  FomSolver solver(scene);
  Snapshot& s = run.frames;
  std::vector<real_t> X, mass, volume;
  solver.reference(X, mass, volume);
  s.num_points = solver.num_particles();
  s.X.assign(X.begin(), X.end());
  s.mass.assign(mass.begin(), mass.end());
  s.volume.assign(volume.begin(), volume.end());
  for (int k = 0; k <= scene.num_outputs; ++k) {
    try {
      solver.advance_to(scene.end_time * k / scene.num_outputs);
    } catch (const SimulationFailure& failure) {
      run.cause = to_string(failure.cause());
      run.message = failure.what();
      run.stopped_at = failure.time();
      break;
    }
    const ParticleFrame f = solver.frame();
    s.time.push_back(f.time);
    s.x.insert(s.x.end(), f.x.begin(), f.x.end());
    s.v.insert(s.v.end(), f.v.begin(), f.v.end());
    s.F.insert(s.F.end(), f.F.begin(), f.F.end());
    s.C.insert(s.C.end(), f.C.begin(), f.C.end());
    ++s.num_frames;
    if (solver.energy_budget() > 0)
      run.energy_ratio = std::max(run.energy_ratio, solver.energy().total() / solver.energy_budget());
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
  if (c.status == "inaccurate") c.cause = "position error " + percent(c.position_error) + " above the threshold";
}

// The studies share one driver: scene variants written next to the report (so every case can be rerun by hand),
// full-order references cached by variant and parameters, and hyper-reductions cached by configuration.
class Study {
 public:
  Study(const StabilitySettings& settings, const std::function<void(const StabilityCase&)>& on_case)
      : settings_(settings), on_case_(on_case), base_(load_scene(settings.scene_path)),
        model_(load_model(settings.model_path)) {
    names_ = base_.design.names;
    if (names_.empty()) throw std::runtime_error(settings.scene_path + " has no [design]: nothing to extrapolate from");
    const auto runs = base_.design.all_runs();
    lo_.assign(names_.size(), 1e300);
    hi_.assign(names_.size(), -1e300);
    for (std::size_t r = 0; r < runs.size(); ++r) {
      const auto& test = base_.design.test_runs;
      if (std::find(test.begin(), test.end(), int(r)) != test.end()) continue;
      for (std::size_t k = 0; k < names_.size(); ++k) {
        lo_[k] = std::min(lo_[k], runs[r][k]);
        hi_[k] = std::max(hi_[k], runs[r][k]);
      }
    }
    std::filesystem::create_directories(std::filesystem::path(settings.out_dir) / "scenes");
    if (settings.selection == SampleSelection::Greedy && !settings.data_dir.empty())
      data_ = load_training_data({settings.data_dir});
  }

  const std::vector<StabilityCase>& cases() const { return cases_; }
  const Model& model() const { return model_; }

  std::vector<double> values_at(double extrapolation, double load_factor = 1) const {
    std::vector<double> v(names_.size());
    for (std::size_t k = 0; k < names_.size(); ++k) v[k] = lo_[k] + (hi_[k] - lo_[k]) * (1.0 + extrapolation);
    v[0] *= load_factor;
    return v;
  }

  // A variant of the scene (overrides of its entries) as a file in DIR/scenes/, named by its label.
  std::string variant(const std::string& label, const std::vector<std::string>& overrides) {
    const auto path = std::filesystem::path(settings_.out_dir) / "scenes" / (label + ".toml");
    if (!written_.count(path.string())) {
      write_file_atomically(path.string(), override_scene(base_, overrides).source_text);
      written_.insert(path.string());
    }
    return path.string();
  }

  std::vector<std::string> horizon_overrides(double horizon) const {
    // left a double: the scene parser checks the count (a whole number in range) before converting it
    const double outputs = std::round(base_.num_outputs * horizon);
    return {"time.end_time=" + number(base_.end_time * outputs / base_.num_outputs, 17),
            "time.outputs=" + number(outputs, 17)};
  }

  const FomRun& reference(const std::string& scene_path, const std::vector<double>& values) {
    std::string key = scene_path;
    for (const double v : values) key += " " + number(v, 17);
    auto it = references_.find(key);
    if (it == references_.end()) it = references_.emplace(key, run_fom(scene_for_run(scene_path, names_, values))).first;
    return it->second;
  }

  const HyperReduction& reduction(RomMethod method, int samples) {
    const auto key = std::make_pair(int(method), samples);
    auto it = reductions_.find(key);
    if (it == reductions_.end()) {
      RomSettings rom;
      rom.method = method;
      rom.samples = samples;
      rom.selection = settings_.selection;
      const auto chosen = select_samples(model_, base_, rom, data_ ? &*data_ : nullptr);
      it = reductions_.emplace(key, build_hyper_reduction(model_, base_, rom, chosen)).first;
    }
    return it->second;
  }

  void fom_case(StabilityCase c, const std::string& scene_path, const std::string& reference_path) {
    const FomRun& ref = reference(reference_path, c.values);
    const FomRun run = run_fom(scene_for_run(scene_path, names_, c.values));
    c.seconds = run.seconds;
    c.details = {{"steps", run.steps}, {"safeguarded_steps", run.safeguarded_steps},
                 {"energy_over_budget", run.energy_ratio}};
    if (!run.cause.empty()) {
      c.cause = run.cause + ": " + run.message;
      c.stopped_at = run.stopped_at;
    }
    record(c, ref, run.frames.num_frames == 0 ? std::vector<ErrorAccumulator>{}
                                               : resolution_errors_by_frame(ref.frames, run.frames),
           !run.cause.empty());
  }

  void rom_case(StabilityCase c, const std::string& scene_path, const RomSettings& rom) {
    const FomRun& ref = reference(scene_path, c.values);
    const auto start = Clock::now();
    const RomResult result =
        run_rollouts(model_, scene_path, names_, {{c.values, ""}}, rom, reduction(rom.method, rom.samples));
    c.seconds = seconds_since(start);
    const RolloutOutcome& o = result.outcomes[0];
    c.details = {{"steps", result.steps},
                 {"max_condition", o.max_condition},
                 {"regularized_steps", o.regularized_steps},
                 {"inversion_failures", o.inversion_failures},
                 {"inversion_fallbacks", o.inversion_fallbacks},
                 {"warning", o.warning}};
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
  Scene base_;
  Model model_;
  std::optional<TrainingData> data_;
  std::vector<std::string> names_;
  std::vector<double> lo_, hi_;
  std::set<std::string> written_;
  std::map<std::string, FomRun> references_;
  std::map<std::pair<int, int>, HyperReduction> reductions_;
  std::vector<StabilityCase> cases_;
};

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

std::string file_label(std::string text) {
  for (char& ch : text)
    if (!std::isalnum(static_cast<unsigned char>(ch))) ch = '_';
  return text;
}

void write_report(const StabilitySettings& settings, const std::vector<StabilityCase>& cases, const Model& model,
                  const std::string& scene_name) {
  const std::filesystem::path dir(settings.out_dir);
  nlohmann::json record = benchmark_record("stability", scene_name);
  record["model"] = settings.model_path;
  record["latent_dim"] = model.latent_dim;
  record["threshold"] = settings.threshold;
  record["cases"] = nlohmann::json::array();
  for (const auto& c : cases) record["cases"].push_back(c.to_json());
  write_file_atomically((dir / "stability.json").string(), record.dump(1) + "\n");

  std::ostringstream md;
  md << "# Stability map: " << scene_name << "\n\n"
     << "Model `" << settings.model_path << "` (r = " << model.latent_dim << "). Each case runs to its end or to the "
     << "first detector that trips; errors are against the full-order model at the scene's time step with the same "
     << "parameters, material and horizon. **unstable**: a detector stopped it; **inaccurate**: position error above "
     << percent(settings.threshold) << "; **stable** otherwise. Time step: the CFL number (1 is the explicit limit). "
     << "Extrapolation: distance beyond the top of the training range in widths of it, every parameter together "
     << "(-0.5 is the centre of the range, 0 its corner).\n";
  const auto table = [&](const std::string& study, const std::string& title) {
    md << "\n## " << title << "\n\n| configuration | time step | horizon | extrapolation | load | material | status | "
       << "position error | final | displacement error | stopped at (s) | cause | wall s |\n"
       << "|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& c : cases) {
      if (c.study != study) continue;
      md << "| " << c.config << " | " << number(c.cfl) << " | " << number(c.horizon) << "x | "
         << number(c.extrapolation) << " | " << number(c.load_factor) << " | "
         << (c.material.empty() ? "scene" : c.material) << " | " << c.status << " | " << percent(c.position_error)
         << " | " << percent(c.final_position_error) << " | " << percent(c.displacement_error) << " | "
         << (c.stopped_at >= 0 ? number(c.stopped_at) : "-") << " | " << c.cause << " | " << number(c.seconds)
         << " |\n";
    }
  };
  table("time_step", "Time step and parameter extrapolation");
  table("horizon", "Horizon");
  table("samples", "Sample points (hyper-reduction)");
  table("material", "Material");
  table("load", "Load (Algorithm 2's Newton inversion)");
  write_file_atomically((dir / "stability.md").string(), md.str());

  // One map per configuration: time step x extrapolation, error as colour, unstable cells marked.
  std::map<std::string, std::vector<const StabilityCase*>> by_config;
  for (const auto& c : cases)
    if (c.study == "time_step") by_config[c.config].push_back(&c);
  for (const auto& [config, list] : by_config) {
    Chart chart{"Stability map, " + scene_name + ": " + config, "time step (CFL number)",
                "extrapolation beyond the training range (widths; -0.5 = centre)", true, false,
                "position error (fraction)", true, {}};
    ChartSeries ok{"stable / inaccurate: colour = position error", {}, {}, "points pt 5 ps 4", {}, {}};
    ChartSeries bad{"unstable (detector)", {}, {}, "points pt 2 ps 3", {}, {}};
    for (const StabilityCase* c : list) {
      const bool broken = c->status == "unstable" || c->status == "no reference";
      ChartSeries& s = broken ? bad : ok;
      s.x.push_back(c->cfl);
      s.y.push_back(c->extrapolation);
      if (!broken) s.color.push_back(std::max(c->position_error, 1e-6));
      s.labels.push_back(broken ? c->cause.substr(0, c->cause.find_first_of(":(;")) : percent(c->position_error));
    }
    chart.series = {ok, bad};
    write_chart(dir.string(), "map_" + file_label(config), chart);
  }
  // Error growth over the longest horizon.
  Chart growth{"Position error over time, " + scene_name + ": a horizon of " + number(settings.horizons.back()) +
                   "x the training window",
               "time (s)", "position error (fraction)", false, true, "", false, {}};
  for (const auto& c : cases)
    if (c.study == "horizon" && c.horizon == settings.horizons.back())
      growth.series.push_back({c.config + (c.status == "unstable" ? " (stopped)" : ""), c.times,
                               c.frame_position_errors, "lines", {}, {}});
  write_chart(dir.string(), "horizon_error", growth);
  // Error against the number of samples.
  Chart samples{"Position error against sample points, " + scene_name, "sample points", "position error (fraction)",
                true, true, "", false, {}};
  for (const std::string method : {"point", "node"}) {
    ChartSeries s{method == "point" ? "Algorithm 1" : "Algorithm 2", {}, {}, "linespoints", {}, {}};
    for (const auto& c : cases)
      if (c.study == "samples" && c.method == method && c.status != "unstable") {
        s.x.push_back(c.samples > 0 ? c.samples : double(model.num_points()));
        s.y.push_back(c.position_error);
      }
    samples.series.push_back(s);
  }
  write_chart(dir.string(), "samples_error", samples);
}

}  // namespace

std::string classify(bool stopped, double position_error, double threshold) {
  if (stopped) return "unstable";
  return position_error > threshold || !std::isfinite(position_error) ? "inaccurate" : "stable";
}

nlohmann::json StabilityCase::to_json() const {
  const auto finite_or_null = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  nlohmann::json errors = nlohmann::json::array();
  for (const double e : frame_position_errors) errors.push_back(finite_or_null(e));
  return {{"study", study},
          {"config", config},
          {"method", method},
          {"samples", samples},
          {"cfl", cfl},
          {"horizon", horizon},
          {"extrapolation", extrapolation},
          {"load_factor", load_factor},
          {"material", material},
          {"values", values},
          {"status", status},
          {"cause", cause},
          {"stopped_at", stopped_at},
          {"position_error", finite_or_null(position_error)},
          {"displacement_error", finite_or_null(displacement_error)},
          {"final_position_error", finite_or_null(final_position_error)},
          {"times", times},
          {"frame_position_errors", errors},
          {"seconds", seconds},
          {"details", details}};
}

std::vector<StabilityCase> run_stability(const StabilitySettings& settings,
                                         const std::function<void(const StabilityCase&)>& on_case) {
  Study study(settings, on_case);
  const Scene base = load_scene(settings.scene_path);
  const std::string scene_path = study.variant("scene", {});
  const auto rom_settings = [&](const RomConfig& config, double cfl) {
    RomSettings rom;
    rom.method = config.method;
    rom.samples = config.samples;
    rom.selection = settings.selection;
    rom.cfl = cfl;
    return rom;
  };

  // On one scene variant: the FOM at CFL 1 (its error against the reference at the scene's cfl is the
  // time-integration error alone), then every ROM configuration at the scene's cfl.
  const auto fom_and_roms = [&](StabilityCase c, const std::string& path, const std::string& fom_path) {
    c.method = "fom";
    c.config = "FOM cfl 1.0";
    c.cfl = 1.0;
    study.fom_case(c, fom_path, path);
    for (const auto& config : rom_configs(settings.samples)) {
      c.method = to_string(config.method);
      c.samples = config.samples;
      c.config = config.label;
      c.cfl = base.cfl;
      study.rom_case(c, path, rom_settings(config, 0));
    }
  };

  // Time step x extrapolation.
  for (const double d : settings.extrapolation) {
    const std::vector<double> values = study.values_at(d);
    for (const bool guarded : {false, true})
      for (const double cfl : settings.fom_cfl) {
        if (guarded && cfl <= settings.fom_max_cfl) continue;  // the safeguard changes nothing there
        StabilityCase c;
        c.study = "time_step";
        c.method = "fom";
        c.config = guarded ? "FOM max_cfl " + number(settings.fom_max_cfl) : "FOM";
        c.cfl = cfl;
        c.extrapolation = d;
        c.values = values;
        std::vector<std::string> overrides{"time.cfl=" + number(cfl, 17)};
        if (guarded) overrides.push_back("time.max_cfl=" + number(settings.fom_max_cfl, 17));
        study.fom_case(c, study.variant(file_label(c.config + " cfl " + number(cfl)), overrides), scene_path);
      }
    for (const auto& config : rom_configs(settings.samples))
      for (const double cfl : settings.rom_cfl) {
        StabilityCase c;
        c.study = "time_step";
        c.method = to_string(config.method);
        c.samples = config.samples;
        c.config = config.label;
        c.cfl = cfl;
        c.extrapolation = d;
        c.values = values;
        study.rom_case(c, scene_path, rom_settings(config, cfl));
      }
  }
  const std::vector<double> centre = study.values_at(-0.5);
  // Horizon, at the scene's time step.
  for (const double horizon : settings.horizons) {
    const std::string path = study.variant("horizon_" + number(horizon), study.horizon_overrides(horizon));
    StabilityCase c;
    c.study = "horizon";
    c.horizon = horizon;
    c.values = centre;
    auto at_limit = study.horizon_overrides(horizon);
    at_limit.push_back("time.cfl=1");
    fom_and_roms(c, path, study.variant("horizon_" + number(horizon) + "_cfl_1", at_limit));
  }
  // Sample points, from r / 3 (under-determined: fewer equations than unknowns) to all.
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
      c.cfl = base.cfl;
      c.values = centre;
      study.rom_case(c, scene_path, rom_settings({c.config, method, count}, 0));
    }
  // Material: nearly incompressible and stiffer than training.
  std::vector<std::pair<std::string, std::string>> materials;
  for (const double nu : settings.poisson_ratios)
    materials.push_back({"nu " + number(nu), "material.poisson_ratio=" + number(nu, 17)});
  materials.push_back({"E x" + number(settings.stiffer),
                       "material.youngs_modulus=" + number(base.material.youngs_modulus * settings.stiffer, 17)});
  for (const auto& [label, override_text] : materials) {
    const std::string path = study.variant(file_label("material " + label), {override_text});
    StabilityCase c;
    c.study = "material";
    c.material = label;
    c.values = centre;
    fom_and_roms(c, path, study.variant(file_label("material " + label + " cfl 1"), {override_text, "time.cfl=1"}));
  }
  // Load: the first design parameter scaled up, for Algorithm 2's inversion under large deformation.
  for (const double factor : settings.load_factors)
    for (const auto& config : rom_configs(settings.samples)) {
      if (config.method != RomMethod::SampleNode) continue;
      StabilityCase c;
      c.study = "load";
      c.method = to_string(config.method);
      c.samples = config.samples;
      c.config = config.label;
      c.cfl = base.cfl;
      c.load_factor = factor;
      c.values = study.values_at(-0.5, factor);
      study.rom_case(c, scene_path, rom_settings(config, 0));
    }
  write_report(settings, study.cases(), study.model(), base.name);
  return study.cases();
}

}  // namespace mpmrom
