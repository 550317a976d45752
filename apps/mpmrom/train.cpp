// mpmrom train: the deformation map on full-order runs, or (--target-error) the cheapest model meeting an error.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "command.hpp"
#include "common.hpp"
#include "core/benchmark_record.hpp"
#include "io/atomic_file.hpp"
#include "studies/pipeline.hpp"

namespace mpmrom::cli {
namespace {

struct TrainOptions {
  std::vector<std::string> train_inputs;
  std::string model_path;
  TrainingSettings training;
  bool resume = false;
  std::vector<double> target_errors;
  std::string search_scene;
  std::vector<std::string> search_networks;
  bool train_json = false;
};

// --target-error: trains and rolls out candidates, keeps the cheapest that meets the first target.
int search(const TrainOptions& o, const Context& context) {
  const bool quiet = context.quiet;
  if (o.search_scene.empty()) throw std::invalid_argument("--target-error needs --scene (the sweep's scene file)");
  if (o.train_inputs.size() != 1) throw std::invalid_argument("--target-error takes one sweep directory");
  mpmrom::PipelineSettings search;
  search.training = o.training;
  search.target_errors = o.target_errors;
  for (const auto& text : o.search_networks) search.networks.push_back(mpmrom::NetworkShape::parse(text));
  const auto decision = mpmrom::search_model(o.search_scene, o.train_inputs[0], o.model_path + ".search", o.model_path,
                                             search, log_lines(quiet));
  if (o.train_json) std::cout << decision.dump() << "\n";
  return 0;
}

int train(const TrainOptions& o, const Context& context) {
  const bool quiet = context.quiet;
  const auto& world = context.world;
  mpmrom::require_writable_output(o.model_path);
  if (!quiet) std::cerr << "mpmrom train: reading " << o.train_inputs.size() << " input(s)\n";
  o.training.validate();
  const auto data = mpmrom::load_training_data(o.train_inputs, {}, mpmrom::training_fields(o.training),
                                               std::size_t(o.training.max_points), o.training.seed);
  if (!quiet)
    std::cerr << "mpmrom train: " << data.train.runs.size() << " training runs, " << data.test.runs.size()
              << " test runs, " << data.train.runs.front().num_points << " points"
              << (data.reference.X.empty() ? "" : " (of " + std::to_string(data.reference.mass.size()) + ")")
              << "; r = " << o.training.latent_dim << ", " << o.training.depth << " layers of " << o.training.width
              << ", lambda1 = " << o.training.lambda_gradient << ", lambda2 = " << o.training.lambda_velocity
              << ", lambda3 = " << o.training.lambda_affine << ", " << o.training.epochs << " epochs\n";
  const std::string checkpoint = o.model_path + ".ckpt";
  mpmrom::TrainingCallbacks callbacks;
  callbacks.progress = [quiet](const mpmrom::TrainingProgress& p) { report_training(p, quiet); };
  callbacks.message = [quiet](const std::string& text) {
    if (!quiet) std::cerr << "mpmrom train: " << text << "\n";
  };
  if (!quiet && world.size() > 1) std::cerr << "mpmrom train: data-parallel over " << world.size() << " processes\n";
  auto model = mpmrom::train_model(data, o.training, checkpoint, o.resume, callbacks, world);
  if (!world.is_root()) return 0;
  if (!quiet) std::cerr << "mpmrom train: ranking " << mpmrom::ranked_samples << " sample points greedily\n";
  model.sample_ranking = mpmrom::rank_samples_greedily(model, data, mpmrom::ranked_samples);
  if (!o.search_scene.empty()) {
    if (!quiet) std::cerr << "mpmrom train: choosing the default sample set on " << o.search_scene << "\n";
    const mpmrom::Scene scene = mpmrom::load_scene(o.search_scene);
    const auto selector = mpmrom::default_projection_selector(model, scene);
    mpmrom::store_projection_samples(model, scene, selector, std::size_t(mpmrom::RomSettings{}.samples),
                                     [quiet](const std::string& line) {
                                       if (!quiet) std::cerr << "mpmrom train: " << line << "\n";
                                     });
  }
  mpmrom::save_model(o.model_path, model);
  std::error_code ignored;
  std::filesystem::remove(checkpoint, ignored);
  if (o.train_json) {
    // a benchmark record (SPEC.md) of the training run, with the model's settings and errors
    auto record = mpmrom::benchmark_record("train", model.scene_name);
    record["model"] = o.model_path;
    record["particles"] = model.num_points();
    record["training_runs"] = data.train.runs.size();
    record["training_snapshots"] = model.num_codes();
    record["test_runs"] = data.test.runs.size();
    record["training_seconds"] = model.errors["training_seconds"];
    if (model.errors.contains("training_samples_per_s"))
      record["training_samples_per_s"] = model.errors["training_samples_per_s"];
    record["settings"] = model.settings;
    record["errors"] = model.errors;
    std::cout << record.dump() << "\n";
  }
  if (!quiet) {
    std::cerr << "mpmrom train: wrote " << o.model_path << "\n";
    for (const char* split : {"train", "validation_points", "test"}) {
      if (!model.errors.contains(split)) continue;
      const auto& e = model.errors[split];
      print_stderr("  %-18s position %.4f %%  displacement %.3f %%  velocity %.3f %%  F %.4f %%  strain %.3f %%\n",
                   split, 100 * e["position_error"].get<double>(), 100 * e["displacement_error"].get<double>(),
                   100 * e["velocity_error"].get<double>(), 100 * e["F_error"].get<double>(),
                   100 * e["strain_error"].get<double>());
      if (e.contains("tangent_velocity_error"))  // the floor any reduced dynamics on the manifold meets
        print_stderr("  %-18s velocity of the best rates on the tangent space %.3f %%\n", "",
                     100 * e["tangent_velocity_error"].get<double>());
    }
  }
  return 0;
}

}  // namespace

void add_train(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<TrainOptions>();
  auto* command = app.add_subcommand("train", "Train the deformation map g(X; xhat) on full-order runs (loss (7))");
  add_input(command, "data", o->train_inputs, "Sweep directories (design.csv splits train/test) or snapshot files",
            CLI::ExistingPath);
  command->add_option("--out", o->model_path, "Model file to write (HDF5)")->required();
  add_network_shape(command, o->training.latent_dim, o->training.width, o->training.depth);
  add_loss_weights(command, o->training.lambda_gradient, o->training.lambda_velocity, o->training.lambda_affine);
  add_defaulted(command, "--epochs", o->training.epochs, "Epochs (each visits every training snapshot once)");
  add_defaulted(command, "--batch-snapshots", o->training.batch_snapshots, "Snapshots per minibatch");
  add_defaulted(command, "--points-per-snapshot", o->training.points_per_snapshot,
                "Material points drawn per snapshot visit");
  add_defaulted(command, "--max-points", o->training.max_points,
                "Read the training runs at this many material points, a random subset (memory and reading time "
                "bounded at any resolution; the model keeps every point); 0: all")
      ->check(CLI::NonNegativeNumber);
  add_defaulted(command, "--learning-rate", o->training.learning_rate, "Adam learning rate, first epoch");
  add_defaulted(command, "--final-learning-rate", o->training.final_learning_rate, "Adam learning rate, last epoch");
  add_defaulted(command, "--validation", o->training.validation_fraction, "Fraction of material points held out");
  add_defaulted(command, "--seed", o->training.seed, "Random seed (initial weights, minibatches, validation points)");
  add_defaulted(command, "--checkpoint-seconds", o->training.checkpoint_seconds,
                "Seconds between checkpoints (MODEL.h5.ckpt)");
  command->add_flag("--resume", o->resume, "Continue from MODEL.h5.ckpt, left by a run that was stopped");
  command
      ->add_option("--target-error", o->target_errors,
                   "Search r, width and samples for the cheapest ROM whose validation position error meets this "
                   "(fraction, e.g. 0.01; several: the first decides MODEL.h5); needs --scene")
      ->check(CLI::PositiveNumber);
  command
      ->add_option("--scene", o->search_scene,
                   "Scene file of the sweep: stores the rollouts' default sample set with the model (greedy "
                   "projection, fitted to the reduced model's motion on it), and runs --target-error's rollouts")
      ->check(CLI::ExistingFile);
  command->add_option("--networks", o->search_networks,
                      "--target-error's networks, r x width x depth (default: r in {3,5,8} x width in {16,32,48})");
  command->add_flag("--json", o->train_json,
                    "Print a benchmark record (device, time, settings, errors) as one JSON object on stdout");
  command->footer(
      "Example: mpmrom train data/poke --out poke_model.h5 --scene scenes/poke_cylinder.toml\n"
      "         mpmrom train data/poke --out small.h5 --target-error 0.01 --scene scenes/poke_cylinder.toml\n"
      "Checkpoints go to MODEL.h5.ckpt while training and are removed once MODEL.h5 is written.");
  commands.push_back(
      {command, [o] { return o->target_errors.empty(); },
       [o](const Context& context) { return o->target_errors.empty() ? train(*o, context) : search(*o, context); }});
}

}  // namespace mpmrom::cli
