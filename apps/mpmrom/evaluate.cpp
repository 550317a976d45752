// mpmrom evaluate: errors of the rollouts in ROM.h5 against full-order runs of any split.
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis/evaluation.hpp"
#include "mpmrom/model.hpp"
#include "rom/rom_file.hpp"
#include "mpmrom/training_data.hpp"

#include "command.hpp"
#include "common.hpp"

namespace mpmrom::cli {
namespace {

struct Options {
  std::string rom_path, evaluate_model;
  std::vector<std::string> references;
  bool evaluate_json = false;
};

// o is a copy: the run completes its settings.
int run(Options o, const Context& context) {
  const bool quiet = context.quiet;
  const mpmrom::RomFile rom = mpmrom::load_rom(o.rom_path);
  const std::string path = o.evaluate_model.empty() ? rom.model_path : o.evaluate_model;
  const mpmrom::Model model = mpmrom::load_model(path);
  if (mpmrom::model_checksum(model) != rom.model_checksum)
    throw std::runtime_error(path + ": not the model " + o.rom_path + " was run with (its weights differ)");
  const auto data = mpmrom::load_runs(o.references);
  const auto errors = mpmrom::evaluate_rom(rom, model, data);
  if (o.evaluate_json) std::cout << errors.dump() << "\n";
  if (!quiet) {
    std::cerr << "mpmrom evaluate: " << errors["matched"] << " of " << errors["rollouts"]
              << " rollouts matched a reference run\n";
    print_metrics("all", errors);
    print_metrics("train", errors["train"]);
    print_metrics("test", errors["test"]);
  }
  return 0;
}

}  // namespace

void add_evaluate(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand("evaluate", "Errors of the rollouts in ROM.h5 against full-order reference runs");
  add_input(command, "rom", o->rom_path, "ROM file (from mpmrom rollout)");
  add_input(command, "references", o->references, "Sweep directories or snapshot files", CLI::ExistingPath);
  command->add_option("--model", o->evaluate_model, "Model file (default: the one ROM.h5 names)");
  command->add_flag("--json", o->evaluate_json, "Print the errors as one JSON object on stdout");
  command->footer("Example: mpmrom evaluate rom.h5 data/poke --json");
  commands.push_back({command, nullptr, [o](const Context& context) { return run(*o, context); }});
}

}  // namespace mpmrom::cli
