#include "studies/pipeline.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "core/benchmark_record.hpp"
#include "studies/charts.hpp"
#include "analysis/evaluation.hpp"
#include "snapshots/simulate.hpp"

namespace mpmrom {

std::string NetworkShape::name() const {
  return "r" + std::to_string(latent_dim) + "_w" + std::to_string(width) + "_d" + std::to_string(depth);
}

NetworkShape NetworkShape::parse(const std::string& text) {
  NetworkShape shape;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%dx%dx%d%c", &shape.latent_dim, &shape.width, &shape.depth, &tail) != 3 ||
      shape.latent_dim < 1 || shape.width < 1 || shape.depth < 2)
    throw std::invalid_argument("network '" + text + "': expected r x width x depth, e.g. 5x48x5 (depth >= 2)");
  return shape;
}

std::string RomConfiguration::name() const {
  char cfl_text[32];
  std::snprintf(cfl_text, sizeof cfl_text, "%g", cfl);
  return to_string(method) + "_s" + std::to_string(samples) + "_cfl" + cfl_text;
}

std::vector<NetworkShape> default_search_networks(int depth) {
  std::vector<NetworkShape> networks;
  for (int width : {16, 32, 48})
    for (int r : {3, 5, 8}) networks.push_back({r, width, depth});
  return networks;
}

// Training runs held out to choose models: those with the most parameters at interior levels of the design (the
// runs most like interpolation, as the test runs are), evenly spread over the design order.
std::vector<std::size_t> validation_runs(const Scene& scene, int requested) {
  const auto runs = scene.design.all_runs();
  std::vector<std::size_t> train;
  for (std::size_t r = 0; r < runs.size(); ++r)
    if (std::find(scene.design.test_runs.begin(), scene.design.test_runs.end(), int(r)) == scene.design.test_runs.end())
      train.push_back(r);
  const std::size_t wanted =
      requested >= 0 ? std::size_t(requested) : std::max<std::size_t>(1, (train.size() + 3) / 6);
  if (wanted >= train.size())
    throw std::runtime_error("cannot hold out " + std::to_string(wanted) + " of " + std::to_string(train.size()) +
                             " training runs for validation");
  std::map<int, std::vector<std::size_t>, std::greater<int>> by_interior;
  for (std::size_t r : train) {
    int interior = 0;
    for (std::size_t k = 0; k < scene.design.names.size(); ++k) {
      double lo = runs[0][k], hi = runs[0][k];
      for (const auto& run : runs) {
        lo = std::min(lo, run[k]);
        hi = std::max(hi, run[k]);
      }
      interior += runs[r][k] > lo && runs[r][k] < hi;
    }
    by_interior[interior].push_back(r);
  }
  std::vector<std::size_t> chosen;
  for (const auto& [interior, group] : by_interior) {
    const std::size_t take = std::min(group.size(), wanted - chosen.size());
    for (std::size_t i = 0; i < take; ++i) chosen.push_back(group[(2 * i + 1) * group.size() / (2 * take)]);
    if (chosen.size() == wanted) break;
  }
  std::sort(chosen.begin(), chosen.end());
  return chosen;
}

// Indices of the points on the lower-left Pareto front of (cost, error), by increasing cost.
std::vector<std::size_t> pareto_front(const std::vector<double>& cost, const std::vector<double>& error) {
  std::vector<std::size_t> order(cost.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return cost[a] < cost[b] || (cost[a] == cost[b] && error[a] < error[b]);
  });
  std::vector<std::size_t> front;
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i : order)
    if (std::isfinite(error[i]) && error[i] < best) {
      front.push_back(i);
      best = error[i];
    }
  return front;
}

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string fixed(double value, int digits) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", digits, value);
  return text;
}

std::string general(double value, int digits = 3) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*g", digits, value);
  return text;
}

std::string percent(double fraction) {
  if (!std::isfinite(fraction)) return "failed";
  return general(100 * fraction, 3) + " %";
}

std::vector<double> run_values(const Snapshot& run, const std::vector<std::string>& names) {
  std::vector<double> values;
  for (const auto& name : names) {
    bool found = false;
    for (const auto& [n, v] : run.header.parameters)
      if (n == name) {
        values.push_back(v);
        found = true;
      }
    if (!found) throw std::runtime_error("a run lacks the design parameter '" + name + "'");
  }
  return values;
}

json metrics_json(const ErrorAccumulator& errors) { return to_json(errors.metrics()); }

// Everything one study (pipeline or search) shares: the scene, the runs, the trained networks and the evaluated
// configurations.
class Study {
 public:
  Study(const PipelineSettings& settings, const std::string& scene_path, const std::string& sweep_dir,
        const std::string& models_dir, PipelineLog log)
      : settings_(settings), scene_path_(scene_path), models_dir_(models_dir), log_(std::move(log)) {
    scene_ = load_scene(scene_path);
    if (scene_.design.names.empty()) throw std::runtime_error(scene_path + ": the scene has no [design]");
    say("reading the runs in " + sweep_dir);
    TrainingData all = load_training_data({sweep_dir});
    const auto held_out = mpmrom::validation_runs(scene_, settings.validation_runs);
    const auto design_runs = scene_.design.all_runs();
    for (std::size_t i = 0; i < all.train.runs.size(); ++i) {
      const auto values = run_values(all.train.runs[i], scene_.design.names);
      bool validation = false;
      for (std::size_t r : held_out) validation = validation || design_runs[r] == values;
      RunSet& set = validation ? validation_ : fit_.train;
      set.files.push_back(all.train.files[i]);
      set.runs.push_back(std::move(all.train.runs[i]));
    }
    fit_.test = std::move(all.test);
    if (validation_.runs.empty() || fit_.test.runs.empty())
      throw std::runtime_error(sweep_dir + ": the pipeline needs validation and test runs");
    say(std::to_string(fit_.train.runs.size()) + " training runs, " + std::to_string(validation_.runs.size()) +
        " validation runs (held out to choose models), " + std::to_string(fit_.test.runs.size()) + " test runs");
  }

  const Scene& scene() const { return scene_; }
  const RunSet& test_runs() const { return fit_.test; }
  const RunSet& validation_runs() const { return validation_; }
  std::size_t training_runs() const { return fit_.train.runs.size(); }
  void set_references(std::vector<Snapshot> references) { references_ = std::move(references); }
  const json& models() const { return models_; }
  const std::vector<json>& configurations() const { return configurations_; }
  void say(const std::string& text) const {
    if (log_) log_(text);
  }

  std::vector<RomConfiguration> configurations_per_network() const {
    std::vector<RomConfiguration> list;
    for (RomMethod method : settings_.methods)
      for (double cfl : settings_.rom_cfls)
        for (int samples : settings_.samples) list.push_back({method, samples, cfl});
    return list;
  }

  // Trains the network (or loads it, trained before with the same settings) and evaluates every configuration on
  // it, once.
  void open(const NetworkShape& shape) {
    if (models_.contains(shape.name())) return;
    const Model model = trained(shape);
    for (const auto& configuration : configurations_per_network()) evaluate(model, shape, configuration);
  }

  bool is_open(const NetworkShape& shape) const { return models_.contains(shape.name()); }

  std::string model_path(const NetworkShape& shape) const { return (fs::path(models_dir_) / (shape.name() + ".h5")).string(); }

  // The cheapest configuration whose validation position error meets the target, searching networks in order of
  // size and training one only while its predicted cost can still beat the best found.
  json search(double target, const std::vector<NetworkShape>& networks) {
    std::vector<NetworkShape> order = networks;
    std::stable_sort(order.begin(), order.end(), [](const NetworkShape& a, const NetworkShape& b) {
      return parameters(a) < parameters(b);
    });
    json skipped = json::array();
    const auto best_meeting = [&]() -> const json* {
      const json* best = nullptr;
      for (const auto& c : configurations_)
        if (c["validation"]["position_error"].get<double>() <= target &&
            (!best || c["cost_seconds_per_simulated_second"] < (*best)["cost_seconds_per_simulated_second"]))
          best = &c;
      return best;
    };
    for (const auto& shape : order) {
      const json* best = best_meeting();
      if (best && !is_open(shape)) {
        const double predicted = predicted_cost(shape);
        if (predicted >= (*best)["cost_seconds_per_simulated_second"].get<double>()) {
          skipped.push_back({{"network", shape.name()}, {"predicted_cost_seconds_per_simulated_second", predicted}});
          continue;
        }
      }
      open(shape);
    }
    json decision = {{"target_position_error", target}, {"skipped_networks", skipped}};
    int evaluated = 0;
    for (const auto& shape : order) evaluated += is_open(shape);
    const json* best = best_meeting();
    if (!best) {
      decision["chosen"] = nullptr;
      decision["why"] = "no configuration of the " + std::to_string(evaluated) +
                        " trained networks meets a validation position error of " + percent(target);
      return decision;
    }
    decision["chosen"] = *best;
    std::ostringstream why;
    why << "the cheapest (" << general((*best)["cost_seconds_per_simulated_second"].get<double>())
        << " s per simulated second per rollout) of the configurations with validation position error <= "
        << percent(target) << ": " << evaluated << " of " << order.size()
        << " networks trained and evaluated in every configuration";
    if (!skipped.empty())
      why << "; " << skipped.size() << " larger networks skipped, their predicted cost (measured cost on a smaller "
          << "network scaled by the parameter count) not below the choice's";
    decision["why"] = why.str();
    return decision;
  }

  // Rollout-steps per second of one configuration as the batch grows (the test cases repeated).
  json batch_throughput(const NetworkShape& shape, const RomConfiguration& configuration) {
    const Model model = load_model(model_path(shape));
    RomSettings rom = rom_settings(configuration);
    rom.end_time = settings_.batch_end_time > 0 ? settings_.batch_end_time
                                                : 4 * scene_.end_time / std::max(1, scene_.num_outputs);
    const auto samples = select_samples(model, scene_, rom, &fit_);
    const auto reduction = build_hyper_reduction(model, scene_, rom, samples);
    json points = json::array();
    for (int batch : settings_.batch_sizes) {
      std::vector<RolloutCase> cases;
      for (int b = 0; b < batch; ++b)
        cases.push_back({run_values(fit_.test.runs[std::size_t(b) % fit_.test.runs.size()], scene_.design.names), "test"});
      const auto result = run_rollouts(model, scene_path_, scene_.design.names, cases, rom, reduction);
      const double rate = result.step_seconds > 0 ? double(result.steps) * batch / result.step_seconds : 0;
      points.push_back({{"batch", batch},
                        {"steps", result.steps},
                        {"rom_step_seconds", result.steps > 0 ? result.step_seconds / result.steps : 0.0},
                        {"rom_rollout_steps_per_s", rate}});
      say("batch " + std::to_string(batch) + ": " + general(rate) + " rollout-steps/s");
    }
    return {{"network", shape.name()}, {"configuration", configuration.name()}, {"end_time", rom.end_time},
            {"points", points}};
  }

 private:
  static double parameters(const NetworkShape& s) {
    return double(nn::MlpLayout::make(s.latent_dim, s.width, s.depth).num_params);
  }

  // The cheapest measured cost of any configuration, on the largest network evaluated so far that is smaller than
  // this one, scaled by the ratio of parameter counts (the network's share of the work).
  double predicted_cost(const NetworkShape& shape) const {
    double cost = std::numeric_limits<double>::infinity(), basis = 0;
    for (const auto& c : configurations_) {
      const double p = c["network_parameters"].get<double>();
      if (p > parameters(shape)) continue;
      if (p > basis) {
        basis = p;
        cost = std::numeric_limits<double>::infinity();
      }
      if (p == basis) cost = std::min(cost, c["cost_seconds_per_simulated_second"].get<double>());
    }
    return basis > 0 ? cost * parameters(shape) / basis : 0.0;
  }

  RomSettings rom_settings(const RomConfiguration& configuration) const {
    RomSettings rom;
    rom.method = configuration.method;
    rom.samples = configuration.samples;
    rom.cfl = configuration.cfl;
    rom.selection = settings_.selection;
    rom.validate();
    return rom;
  }

  Model trained(const NetworkShape& shape) {
    TrainingSettings training = settings_.training;
    training.latent_dim = shape.latent_dim;
    training.width = shape.width;
    training.depth = shape.depth;
    training.validate();
    const std::string path = model_path(shape), history_path = path + ".history.json";
    fs::create_directories(models_dir_);
    json history = json::array();
    Model model;
    if (fs::exists(path)) {
      model = load_model(path);
      if (model.settings == training.to_json() && model.runs.size() == fit_.train.runs.size()) {
        say("network " + shape.name() + ": reusing " + path);
        if (model.sample_ranking.empty()) {  // a model written before rollouts took their samples from it
          model.sample_ranking = rank_samples_greedily(model, fit_, ranked_samples);
          save_model(path, model);
        }
        if (fs::exists(history_path)) std::ifstream(history_path) >> history;
        record_model(shape, model, history, path);
        return model;
      }
      say("network " + shape.name() + ": " + path + " was trained with other settings; training again");
    }
    say("network " + shape.name() + ": training (" + std::to_string(training.epochs) + " epochs)");
    TrainingCallbacks callbacks;
    callbacks.progress = [&](const TrainingProgress& p) {
      json entry = {{"epoch", p.epoch}, {"loss", p.train.total}, {"seconds", p.seconds}};
      if (p.validated) entry["validation_loss"] = p.validation.total;
      history.push_back(entry);
      if (p.validated || p.epoch == p.epochs)
        say("  epoch " + std::to_string(p.epoch) + "/" + std::to_string(p.epochs) + "  loss " + general(p.train.total) +
            (p.validated ? "  validation " + general(p.validation.total) : "") + "  " +
            general(p.seconds_left, 2) + " s left");
    };
    const std::string checkpoint = path + ".ckpt";
    model = train_model(fit_, training, checkpoint, fs::exists(checkpoint), callbacks);
    model.sample_ranking = rank_samples_greedily(model, fit_, ranked_samples);
    save_model(path, model);
    write_file_atomically(history_path, history.dump());
    std::error_code ignored;
    fs::remove(checkpoint, ignored);
    record_model(shape, model, history, path);
    return model;
  }

  void record_model(const NetworkShape& shape, const Model& model, const json& history, const std::string& path) {
    json entry = {{"network", shape.name()},
                  {"latent_dim", shape.latent_dim},
                  {"width", shape.width},
                  {"depth", shape.depth},
                  {"parameters", parameters(shape)},
                  {"path", fs::relative(path, fs::path(models_dir_).parent_path()).string()},
                  {"errors", model.errors},
                  {"loss_history", history}};
    models_[shape.name()] = entry;
  }

  void evaluate(const Model& model, const NetworkShape& shape, const RomConfiguration& configuration) {
    const RomSettings rom = rom_settings(configuration);
    const auto samples = select_samples(model, scene_, rom, &fit_);
    const auto reduction = build_hyper_reduction(model, scene_, rom, samples);
    std::vector<RolloutCase> cases;
    std::vector<const Snapshot*> runs;
    for (const auto& run : validation_.runs) {
      cases.push_back({run_values(run, scene_.design.names), "validation"});
      runs.push_back(&run);
    }
    for (const auto& run : fit_.test.runs) {
      cases.push_back({run_values(run, scene_.design.names), "test"});
      runs.push_back(&run);
    }
    const auto result = run_rollouts(model, scene_path_, scene_.design.names, cases, rom, reduction);
    const std::size_t frames = result.times.size(), r = std::size_t(result.latent_dim);
    ErrorAccumulator validation, test, test_reference;
    int failures = 0;
    std::string failure;
    for (std::size_t b = 0; b < cases.size(); ++b) {
      if (!result.outcomes[b].message.empty()) {
        ++failures;
        failure = result.outcomes[b].message;
        continue;
      }
      const std::vector<double> xhat(result.xhat.begin() + b * frames * r, result.xhat.begin() + (b + 1) * frames * r);
      const std::vector<double> xhatdot(result.xhatdot.begin() + b * frames * r,
                                        result.xhatdot.begin() + (b + 1) * frames * r);
      const auto errors = rollout_errors(model, *runs[b], xhat, xhatdot);
      (cases[b].split == "validation" ? validation : test).merge(errors);
      const std::size_t t = b - validation_.runs.size();
      if (cases[b].split == "test" && t < references_.size())
        test_reference.merge(rollout_errors(model, references_[t], xhat, xhatdot));
    }
    const double simulated = result.times.back() - result.times.front();
    const double cost = result.step_seconds / (double(cases.size()) * simulated);
    json entry = {{"network", shape.name()},
                  {"network_parameters", parameters(shape)},
                  {"configuration", configuration.name()},
                  {"method", to_string(configuration.method)},
                  {"samples", configuration.samples},
                  {"cfl", configuration.cfl > 0 ? configuration.cfl : scene_.cfl},
                  {"hyper_reduction", reduction.summary()},
                  {"rollouts", cases.size()},
                  {"steps", result.steps},
                  {"rom_seconds_per_rollout_step", result.step_seconds / (double(result.steps) * cases.size())},
                  {"cost_seconds_per_simulated_second", cost},
                  {"validation", metrics_json(validation)},
                  {"test", metrics_json(test)}};
    if (!references_.empty()) entry["test_vs_reference"] = metrics_json(test_reference);
    if (failures > 0) {
      // a failed rollout disqualifies the configuration: its errors cannot be measured over the whole horizon
      for (const char* split : {"validation", "test", "test_vs_reference"})
        if (entry.contains(split))
          for (auto& [key, value] : entry[split].items()) value = std::numeric_limits<double>::infinity();
      entry["failed_rollouts"] = failures;
      entry["failure"] = failure;
    }
    say("  " + shape.name() + " " + configuration.name() + ": " + std::to_string(result.steps) + " steps, " +
        general(cost) + " s per simulated second, validation " + percent(entry["validation"]["position_error"]) +
        ", test " + percent(entry["test"]["position_error"]) + (failures ? ", " + failure : ""));
    configurations_.push_back(entry);
  }

  PipelineSettings settings_;
  std::string scene_path_, models_dir_;
  PipelineLog log_;
  Scene scene_;
  TrainingData fit_;
  RunSet validation_;
  std::vector<Snapshot> references_;
  json models_ = json::object();
  std::vector<json> configurations_;
};

double number(const json& value) {
  return value.is_number() ? value.get<double>() : std::numeric_limits<double>::infinity();
}

// The FOM's resolution ladder on the test runs: every level against the reference, with its cost.
json fom_ladder(const PipelineSettings& settings, const Study& study, std::vector<Snapshot>& references) {
  const Scene& scene = study.scene();
  const auto& names = scene.design.names;
  struct Level {
    double refinement, cfl;
    bool reference;
  };
  std::vector<Level> levels{{settings.reference_refinement, 0, true}};
  for (double cfl : settings.fom_cfls)
    for (double f : settings.fom_refinements) levels.push_back({f, cfl, false});
  json ladder = json::array();
  for (const auto& level : levels) {
    const std::string name = level.reference ? "reference" : "x" + general(level.refinement) + "_cfl" +
                                                                 general(level.cfl > 0 ? level.cfl : scene.cfl);
    const fs::path dir = fs::path(settings.out_dir) / "fom" / name;
    fs::create_directories(dir);
    ErrorAccumulator errors;
    double step_seconds = 0, simulated = 0;
    long steps = 0;
    std::size_t particles = 0;
    double dx = 0;
    for (std::size_t t = 0; t < study.test_runs().runs.size(); ++t) {
      Scene run = refine_scene(scene_for_run(settings.scene_path, names, run_values(study.test_runs().runs[t], names)),
                               level.refinement);
      if (level.cfl > 0) run = override_scene(run, {"time.cfl=" + general(level.cfl, 17)});
      const std::string path = (dir / fs::path(study.test_runs().files[t]).filename()).string();
      SimulationProgress last{};
      simulate(run, path, default_p2g_strategy(), [&](const SimulationProgress& p) { last = p; });
      step_seconds += last.step_seconds;
      steps += last.steps;
      simulated += run.end_time;
      particles = last.num_particles;
      dx = run.dx;
      if (level.reference)
        references.push_back(read_snapshot(path, SnapshotFields::WithoutAffine));
      else
        errors.merge(resolution_errors(references[t], read_snapshot(path)));
    }
    json entry = {{"name", name},
                  {"refinement", level.refinement},
                  {"cfl", level.cfl > 0 ? level.cfl : scene.cfl},
                  {"dx", dx},
                  {"particles", particles},
                  {"runs", study.test_runs().runs.size()},
                  {"steps_per_run", double(steps) / study.test_runs().runs.size()},
                  {"fom_step_seconds", step_seconds / steps},
                  {"cost_seconds_per_simulated_second", step_seconds / simulated},
                  {"reference", level.reference}};
    if (!level.reference) entry["test_vs_reference"] = metrics_json(errors);
    study.say("FOM " + name + ": " + std::to_string(particles) + " particles, " +
              general(step_seconds / simulated) + " s per simulated second" +
              (level.reference ? " (the reference)" : ", position error " +
                                                          percent(entry["test_vs_reference"]["position_error"])));
    ladder.push_back(entry);
  }
  return ladder;
}

// The ROM's Pareto front against the FOM ladder: for each front point, the best FOM error at equal or lower cost.
json compare_fronts(const json& ladder, const std::vector<json>& configurations, const std::string& metric) {
  std::vector<double> fom_cost, fom_error;
  for (const auto& level : ladder)
    if (!level["reference"].get<bool>()) {
      fom_cost.push_back(level["cost_seconds_per_simulated_second"]);
      fom_error.push_back(number(level["test_vs_reference"][metric]));
    }
  std::vector<double> rom_cost, rom_error;
  for (const auto& c : configurations) {
    rom_cost.push_back(c["cost_seconds_per_simulated_second"]);
    rom_error.push_back(c.contains("test_vs_reference") ? number(c["test_vs_reference"][metric])
                                                        : std::numeric_limits<double>::infinity());
  }
  json points = json::array();
  double below_lo = INFINITY, below_hi = 0;
  int below = 0;
  const auto front = pareto_front(rom_cost, rom_error);
  for (std::size_t i : front) {
    double fom_best = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < fom_cost.size(); ++k)
      if (fom_cost[k] <= rom_cost[i]) fom_best = std::min(fom_best, fom_error[k]);
    const bool rom_better = rom_error[i] < fom_best;
    if (rom_better) {
      ++below;
      below_lo = std::min(below_lo, rom_cost[i]);
      below_hi = std::max(below_hi, rom_cost[i]);
    }
    points.push_back({{"network", configurations[i]["network"]},
                      {"configuration", configurations[i]["configuration"]},
                      {"cost_seconds_per_simulated_second", rom_cost[i]},
                      {"error", rom_error[i]},
                      {"best_fom_error_at_equal_or_lower_cost",
                       std::isfinite(fom_best) ? json(fom_best) : json("no FOM level this cheap")},
                      {"rom_below_fom", rom_better}});
  }
  json result = {{"metric", metric}, {"front", points}, {"front_points_below_fom", below}};
  if (below > 0)
    result["range_seconds_per_simulated_second"] = {below_lo, below_hi};
  return result;
}

std::string verdict_text(const json& comparison) {
  const int below = comparison["front_points_below_fom"];
  const std::size_t total = comparison["front"].size();
  const std::string metric = comparison["metric"];
  if (below == 0)
    return "No point of the ROM's Pareto front (" + metric + " against the reference) lies below the FOM curve: at " +
           "every cost the ROM reaches, some FOM resolution that costs no more is at least as accurate.";
  return std::to_string(below) + " of the " + std::to_string(total) + " points of the ROM's Pareto front (" + metric +
         ") lie below the FOM curve (lower error than every FOM level of equal or lower cost), between " +
         general(comparison["range_seconds_per_simulated_second"][0].get<double>()) + " and " +
         general(comparison["range_seconds_per_simulated_second"][1].get<double>()) + " s per simulated second.";
}

std::vector<std::string> draw_charts(const std::string& dir, const json& report) {
  std::vector<std::string> problems;
  const auto draw = [&](const std::string& name, const Chart& chart) {
    const std::string problem = write_chart(dir, name, chart);
    if (!problem.empty()) problems.push_back(problem);
  };
  const auto& ladder = report["fom"];
  const auto& configurations = report["rom"];
  for (const std::string metric : {"position_error", "displacement_error"}) {
    Chart chart;
    chart.title = report["scene"].get<std::string>() + ": error against cost (test runs, against the " +
                  general(report["reference_refinement"].get<double>()) + "x finer FOM)";
    chart.x_label = "cost: wall seconds per simulated second per run (" + report["device"].get<std::string>() + ")";
    chart.y_label = metric + " (%)";
    chart.log_x = chart.log_y = true;
    std::map<double, ChartSeries> fom_by_cfl;
    for (const auto& level : ladder) {
      if (level["reference"].get<bool>()) continue;
      auto& series = fom_by_cfl[level["cfl"].get<double>()];
      series.title = "FOM, resolutions (cfl " + general(level["cfl"].get<double>()) + ")";
      series.style = "linespoints";
      series.x.push_back(level["cost_seconds_per_simulated_second"]);
      series.y.push_back(100 * number(level["test_vs_reference"][metric]));
      series.labels.push_back("x" + general(level["refinement"].get<double>()));
    }
    std::vector<double> cost, error;
    std::map<std::string, ChartSeries> rom_by_method;
    for (const auto& c : configurations) {
      cost.push_back(c["cost_seconds_per_simulated_second"]);
      error.push_back(number(c["test_vs_reference"][metric]));
      auto& series = rom_by_method[c["method"].get<std::string>()];
      series.title = "ROM configurations, " + std::string(c["method"] == "point" ? "Algorithm 1" : "Algorithm 2");
      series.x.push_back(cost.back());
      series.y.push_back(100 * error.back());
    }
    for (auto& [cfl, series] : fom_by_cfl) chart.series.push_back(series);
    for (auto& [method, series] : rom_by_method) chart.series.push_back(series);
    ChartSeries front{"ROM Pareto front", {}, {}, "linespoints", {}, {}};
    for (std::size_t i : pareto_front(cost, error)) {
      front.x.push_back(cost[i]);
      front.y.push_back(100 * error[i]);
      front.labels.push_back(configurations[i]["network"].get<std::string>() + " " +
                             configurations[i]["configuration"].get<std::string>());
    }
    chart.series.push_back(front);
    draw(metric == "position_error" ? "error_vs_cost" : "error_vs_cost_displacement", chart);
  }
  {
    Chart chart;
    chart.title = report["scene"].get<std::string>() + ": cost of one step against the particle count";
    chart.x_label = "material points (FOM particles; ROM: the model's points)";
    chart.y_label = "wall seconds per step (ROM: per rollout-step)";
    chart.log_x = chart.log_y = true;
    ChartSeries fom{"FOM, scene's cfl", {}, {}, "linespoints", {}, {}}, rom{"ROM configurations", {}, {}, "points", {}, {}};
    for (const auto& level : ladder)
      if (level["cfl"] == ladder[0]["cfl"] || level["reference"].get<bool>()) {
        fom.x.push_back(level["particles"]);
        fom.y.push_back(level["fom_step_seconds"]);
      }
    for (const auto& c : configurations) {
      rom.x.push_back(report["particles"]);
      rom.y.push_back(c["rom_seconds_per_rollout_step"]);
    }
    // ascending particle count so the line reads left to right
    std::vector<std::size_t> order(fom.x.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return fom.x[a] < fom.x[b]; });
    ChartSeries sorted{fom.title, {}, {}, fom.style, {}, {}};
    for (std::size_t i : order) {
      sorted.x.push_back(fom.x[i]);
      sorted.y.push_back(fom.y[i]);
    }
    chart.series = {sorted, rom};
    draw("step_cost_vs_particles", chart);
  }
  if (report.contains("batch")) {
    Chart chart;
    chart.title = "Batch throughput: " + report["batch"]["network"].get<std::string>() + " " +
                  report["batch"]["configuration"].get<std::string>();
    chart.x_label = "rollouts in the batch";
    chart.y_label = "rollout-steps per second";
    chart.log_x = chart.log_y = true;
    ChartSeries series{report["device"].get<std::string>() + " (" + report["backend"].get<std::string>() + ")", {}, {},
                       "linespoints", {}, {}};
    for (const auto& p : report["batch"]["points"]) {
      series.x.push_back(p["batch"]);
      series.y.push_back(p["rom_rollout_steps_per_s"]);
    }
    chart.series = {series};
    draw("batch_throughput", chart);
  }
  {
    Chart chart;
    chart.title = "Training loss (7), relative terms summed";
    chart.x_label = "epoch";
    chart.y_label = "minibatch loss";
    chart.log_y = true;
    for (const auto& [name, model] : report["models"].items()) {
      ChartSeries series{name, {}, {}, "lines", {}, {}};
      for (const auto& h : model["loss_history"]) {
        series.x.push_back(h["epoch"]);
        series.y.push_back(h["loss"]);
      }
      if (!series.x.empty()) chart.series.push_back(series);
    }
    if (!chart.series.empty()) draw("training_loss", chart);
  }
  return problems;
}

std::string metrics_cells(const json& m) {
  std::string cells;
  for (const char* key : {"position_error", "displacement_error", "velocity_error", "F_error", "strain_error"})
    cells += " " + percent(number(m[key])) + " |";
  return cells;
}

std::string markdown(const json& report, const std::vector<std::string>& chart_problems) {
  std::ostringstream md;
  md << "# Pipeline report: " << report["scene"].get<std::string>() << "\n\n";
  md << "Generated by `" << report["command"].get<std::string>() << "` on " << report["device"].get<std::string>()
     << " (" << report["backend"].get<std::string>() << ", " << report["threads"] << " threads, "
     << report["precision"].get<std::string>() << ", mpmrom " << report["git_commit"].get<std::string>()
     << "), total " << fixed(report["wall_seconds"].get<double>() / 60, 1)
     << " min. Every figure is in `report.json`; the method is described in docs/pipeline.md.\n\n";
  md << "Runs: " << report["runs"]["train"] << " training, " << report["runs"]["validation"]
     << " validation (held out to choose models), " << report["runs"]["test"]
     << " test (used for no choice). Errors are SPEC.md's metrics over all material points and output times; cost is "
        "wall-clock seconds of stepping per simulated second per run (ROM: per rollout, in a batch of the validation "
        "and test rollouts).\n\n";
  md << "## Speed against accuracy\n\n![error against cost](error_vs_cost.png)\n\n";
  md << verdict_text(report["comparison"]["position_error"]) << "\n\n";
  md << "With the strict metric (displacement error): " << verdict_text(report["comparison"]["displacement_error"])
     << "\n\n![displacement error against cost](error_vs_cost_displacement.png)\n\n";
  md << "### Full-order model: resolutions against the " << general(report["reference_refinement"].get<double>())
     << "x finer reference\n\n";
  md << "| level | particles | dx (m) | cfl | steps | ms/step | s per simulated s | position | displacement | velocity | "
        "F | strain |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
  for (const auto& level : report["fom"]) {
    md << "| " << level["name"].get<std::string>() << " | " << level["particles"] << " | "
       << general(level["dx"].get<double>()) << " | " << general(level["cfl"].get<double>()) << " | "
       << general(level["steps_per_run"].get<double>()) << " | "
       << general(1e3 * level["fom_step_seconds"].get<double>()) << " | "
       << general(level["cost_seconds_per_simulated_second"].get<double>()) << " |";
    md << (level["reference"].get<bool>() ? " (reference) | | | | |" : metrics_cells(level["test_vs_reference"])) << "\n";
  }
  md << "\n### Reduced-order model configurations\n\n";
  md << "Errors on the test runs against the training-resolution FOM (the paper's comparison) and, last column, the "
        "position error against the reference.\n\n";
  md << "| network | configuration | evaluated points | steps | ms/rollout-step | s per simulated s | validation "
        "position | position | displacement | velocity | F | strain | position vs reference |\n"
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
  for (const auto& c : report["rom"]) {
    const auto& h = c["hyper_reduction"];
    md << "| " << c["network"].get<std::string>() << " | " << c["configuration"].get<std::string>() << " | "
       << (h.contains("source_points") && h["source_points"].get<long>() > 0 ? h["source_points"] : h["quadrature_points"])
       << " | " << c["steps"] << " | " << general(1e3 * c["rom_seconds_per_rollout_step"].get<double>()) << " | "
       << general(c["cost_seconds_per_simulated_second"].get<double>()) << " | "
       << percent(number(c["validation"]["position_error"])) << " |" << metrics_cells(c["test"]) << " "
       << percent(number(c["test_vs_reference"]["position_error"])) << " |\n";
  }
  md << "\n### Models\n\n| network | parameters | reconstruction position error train / test | training time |\n"
        "| --- | --- | --- | --- |\n";
  for (const auto& [name, m] : report["models"].items()) {
    const auto& e = m["errors"];
    md << "| " << name << " | " << general(m["parameters"].get<double>(), 9) << " | "
       << (e.contains("train") ? percent(number(e["train"]["position_error"])) : "?") << " / "
       << (e.contains("test") ? percent(number(e["test"]["position_error"])) : "?") << " | "
       << (e.contains("training_seconds") ? general(e["training_seconds"].get<double>()) + " s" : "?") << " |\n";
  }
  md << "\n![training loss](training_loss.png)\n\n";
  if (report.contains("targets") && !report["targets"].empty()) {
    md << "## The smallest model that meets a target\n\n";
    md << "| target (validation position error) | chosen | s per simulated s | validation | test position | why |\n"
          "| --- | --- | --- | --- | --- | --- |\n";
    for (const auto& t : report["targets"]) {
      md << "| " << percent(t["target_position_error"].get<double>()) << " | ";
      if (t["chosen"].is_null()) {
        md << "none | | | | " << t["why"].get<std::string>() << " |\n";
        continue;
      }
      const auto& c = t["chosen"];
      md << c["network"].get<std::string>() << " " << c["configuration"].get<std::string>() << " | "
         << general(c["cost_seconds_per_simulated_second"].get<double>()) << " | "
         << percent(number(c["validation"]["position_error"])) << " | " << percent(number(c["test"]["position_error"]))
         << (number(c["test"]["position_error"]) <= t["target_position_error"].get<double>() ? " (meets it)"
                                                                                              : " (misses it)")
         << " | " << t["why"].get<std::string>() << " |\n";
    }
    md << "\n";
  }
  md << "## Cost against particle count\n\n![step cost against particles](step_cost_vs_particles.png)\n\n";
  if (report.contains("batch")) {
    md << "## Batch throughput\n\n" << report["batch"]["network"].get<std::string>() << " "
       << report["batch"]["configuration"].get<std::string>() << ", horizon "
       << general(report["batch"]["end_time"].get<double>()) << " s:\n\n| rollouts | rollout-steps/s | ms per step |\n"
       << "| --- | --- | --- |\n";
    for (const auto& p : report["batch"]["points"])
      md << "| " << p["batch"] << " | " << general(p["rom_rollout_steps_per_s"].get<double>()) << " | "
         << general(1e3 * p["rom_step_seconds"].get<double>()) << " |\n";
    md << "\n![batch throughput](batch_throughput.png)\n\n";
  }
  if (!chart_problems.empty()) {
    md << "Charts not drawn:";
    for (const auto& p : chart_problems) md << " " << p << ".";
    md << "\n";
  }
  return md.str();
}

}  // namespace

json run_pipeline(const PipelineSettings& settings, const PipelineLog& log) {
  const auto start = std::chrono::steady_clock::now();
  const auto say = [&](const std::string& text) {
    if (log) log(text);
  };
  const fs::path out(settings.out_dir);
  fs::create_directories(out);
  const std::string data_dir = (out / "data").string();
  if (fs::exists(fs::path(data_dir) / "design.csv")) {
    say("sweep: reusing " + data_dir);
  } else {
    say("sweep: the scene's design into " + data_dir);
    // A pipeline stopped during its sweep keeps the runs it finished (resume).
    sweep(
        settings.scene_path, data_dir, default_p2g_strategy(),
        [&](std::size_t run, std::size_t runs, const SweepRun&, bool reused) {
          say("  run " + std::to_string(run + 1) + "/" + std::to_string(runs) + (reused ? " (finished before)" : ""));
        },
        {}, true);
  }
  Study study(settings, settings.scene_path, data_dir, (out / "models").string(), log);
  const Scene& scene = study.scene();

  say("FOM at " + std::to_string(settings.fom_refinements.size()) + " resolutions and the " +
      general(settings.reference_refinement) + "x reference, on the test runs");
  std::vector<Snapshot> references;
  const json ladder = fom_ladder(settings, study, references);
  study.set_references(std::move(references));

  std::vector<NetworkShape> networks = settings.networks;
  if (networks.empty()) {
    if (settings.target_errors.empty())
      networks.push_back({settings.training.latent_dim, settings.training.width, settings.training.depth});
    else
      networks = default_search_networks(settings.training.depth);
  }
  json targets = json::array();
  if (settings.target_errors.empty()) {
    for (const auto& shape : networks) study.open(shape);
  } else {
    for (double target : settings.target_errors) {
      say("search: the cheapest configuration with validation position error <= " + percent(target));
      targets.push_back(study.search(target, networks));
      say("search: " + targets.back()["why"].get<std::string>());
    }
  }

  json report = benchmark_record("pipeline", scene.name);
  report["command"] = !settings.command.empty() ? settings.command
                                                : "mpmrom pipeline " + settings.scene_path + " --out " + settings.out_dir;
  report["particles"] = study.test_runs().runs.front().num_points;
  report["reference_refinement"] = settings.reference_refinement;
  report["runs"] = {{"train", study.training_runs()},
                    {"validation", study.validation_runs().runs.size()},
                    {"test", study.test_runs().runs.size()}};
  report["fom"] = ladder;
  report["models"] = study.models();
  report["rom"] = study.configurations();
  report["targets"] = targets;
  report["comparison"] = {{"position_error", compare_fronts(ladder, study.configurations(), "position_error")},
                          {"displacement_error", compare_fronts(ladder, study.configurations(), "displacement_error")}};

  // the batch benchmark runs the first target's choice; without targets, the cheapest configuration within 1 % on
  // validation, else the most accurate one
  const json* chosen = !targets.empty() && !targets[0]["chosen"].is_null() ? &targets[0]["chosen"] : nullptr;
  if (targets.empty()) {
    const auto validation_error = [](const json& c) { return number(c["validation"]["position_error"]); };
    for (const auto& c : study.configurations())
      if (validation_error(c) <= 0.01 && (!chosen || number(c["cost_seconds_per_simulated_second"]) <
                                                         number((*chosen)["cost_seconds_per_simulated_second"])))
        chosen = &c;
    if (!chosen)
      for (const auto& c : study.configurations())
        if (!chosen || validation_error(c) < validation_error(*chosen)) chosen = &c;
  }
  if (chosen && !settings.batch_sizes.empty()) {
    say("batch throughput of " + (*chosen)["network"].get<std::string>() + " " +
        (*chosen)["configuration"].get<std::string>());
    const auto& models = study.models();
    const auto& m = models[(*chosen)["network"].get<std::string>()];
    const RomConfiguration configuration{rom_method_from_string((*chosen)["method"].get<std::string>()),
                                         (*chosen)["samples"].get<int>(), (*chosen)["cfl"].get<double>()};
    report["batch"] = study.batch_throughput(
        {m["latent_dim"].get<int>(), m["width"].get<int>(), m["depth"].get<int>()}, configuration);
  }
  report["wall_seconds"] = seconds_since(start);
  const auto problems = draw_charts(settings.out_dir, report);
  for (const auto& p : problems) say("charts: " + p);
  write_file_atomically((out / "report.json").string(), report.dump(1) + "\n");
  write_file_atomically((out / "report.md").string(), markdown(report, problems));
  say("wrote " + (out / "report.md").string() + " and report.json");
  return report;
}

json search_model(const std::string& scene_path, const std::string& sweep_dir, const std::string& work_dir,
                  const std::string& model_path, const PipelineSettings& settings, const PipelineLog& log) {
  Study study(settings, scene_path, sweep_dir, work_dir, log);
  const std::vector<NetworkShape> networks =
      settings.networks.empty() ? default_search_networks(settings.training.depth) : settings.networks;
  json decisions = json::array();
  for (double target : settings.target_errors) {
    study.say("search: the cheapest configuration with validation position error <= " + percent(target));
    decisions.push_back(study.search(target, networks));
    study.say("search: " + decisions.back()["why"].get<std::string>());
  }
  if (decisions.empty()) throw std::invalid_argument("search_model needs at least one target error");
  const json& first = decisions[0];
  if (first["chosen"].is_null()) throw std::runtime_error(first["why"].get<std::string>());
  const auto& m = study.models()[first["chosen"]["network"].get<std::string>()];
  save_model(model_path,
             load_model(study.model_path({m["latent_dim"].get<int>(), m["width"].get<int>(), m["depth"].get<int>()})));
  return {{"targets", decisions}, {"models", study.models()}, {"model", model_path}};
}

}  // namespace mpmrom
