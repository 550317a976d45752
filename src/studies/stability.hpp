// The stability map (docs/stability.md): where the full-order model and each reduced configuration break, over the
// time step, the horizon, parameter extrapolation, the number of sample points, the material and the load. Every
// case runs to its end or to the first detector that trips; each is compared with a full-order reference at the
// scene's own time step and the same parameters, material and horizon.
#pragma once

#include <nlohmann/json.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "mpmrom/rom.hpp"

namespace mpmrom {

struct StabilitySettings {
  std::string scene_path;  // the scene of the sweep the model was trained on
  std::string model_path;
  std::string data_dir;  // the sweep: the velocity-fitted greedy selection (--selection greedy) fits its training runs
  std::string out_dir;
  int samples = 15;  // the hyper-reduced configurations' sample points
  // nullopt: each method's own default, as a rollout without flags (docs/rom.md "Defaults"): Algorithm 1 the model's
  // stored greedy projection set with its fitted weights, Algorithm 2 its samples fitted to its own step.
  std::optional<SampleSelection> selection;
  // A run no detector stopped still counts as failed when its position error exceeds this (fraction).
  double threshold = 0.05;
  double fom_max_cfl = 0.5;  // the FOM's sub-stepping safeguard, mapped beside the FOM without it
  std::vector<double> fom_cfl{0.2, 0.4, 0.6, 0.9, 1.2, 2.0};
  std::vector<double> rom_cfl{0.3, 1.0, 3.0, 10.0};
  // Distance beyond the top of the training range, in widths of it, all parameters together (-0.5: the centre).
  std::vector<double> extrapolation{-0.5, 0.0, 0.5, 1.0};
  std::vector<double> horizons{1, 4, 10};        // multiples of the training window
  std::vector<double> load_factors{1, 2, 4, 8};  // the first design parameter, times this (Algorithm 2's Newton)
  std::vector<double> poisson_ratios{0.45, 0.49};
  double stiffer = 4;  // Young's modulus times this
};

// One case: what ran and what became of it.
struct StabilityCase {
  std::string study;   // time_step, horizon, samples, material, load
  std::string config;  // "FOM", "FOM max_cfl 0.9", "A1 15 samples", "A2 all points", ...
  std::string method;  // fom, point or node
  int samples = 0;     // ROM: sample points (0: all)
  double cfl = 0, horizon = 1, extrapolation = -0.5, load_factor = 1;
  std::string material;  // empty: the scene's; else the override
  std::vector<double> values;

  std::string status;  // stable, inaccurate, unstable, or "no reference" when the reference itself failed
  std::string cause;   // the detector that stopped it, or the error above the threshold
  double stopped_at = -1;
  double position_error = 0, displacement_error = 0, final_position_error = 0;
  std::vector<double> times, frame_position_errors;
  double seconds = 0;
  nlohmann::json details = nlohmann::json::object();  // detector counts: inversions, regularised steps, ...

  nlohmann::json to_json() const;
};

// A case is unstable if a detector stopped it, inaccurate if its position error exceeds the threshold, else stable.
std::string classify(bool stopped, double position_error, double threshold);

// Runs every study and writes DIR/stability.json, DIR/stability.md and the charts; returns the cases.
std::vector<StabilityCase> run_stability(const StabilitySettings& settings,
                                         const std::function<void(const StabilityCase&)>& on_case = {});

}  // namespace mpmrom
