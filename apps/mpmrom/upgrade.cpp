// mpmrom upgrade: files of older mpmrom versions rewritten in the current formats.
#include <exception>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "analysis/upgrade.hpp"

#include "command.hpp"
#include "common.hpp"

namespace mpmrom::cli {
namespace {

struct Options {
  std::vector<std::string> upgrade_files;
};

// o is a copy: the run completes its settings.
int run(Options o, const Context& context) {
  const bool quiet = context.quiet;
  int failed = 0;
  for (const auto& file : o.upgrade_files) {
    try {
      const std::string done = mpmrom::upgrade_file(file);
      if (!quiet) std::cerr << "mpmrom upgrade: " << done << "\n";
    } catch (const std::exception& e) {
      ++failed;
      std::cerr << "mpmrom: error: " << e.what() << "\n";
    }
  }
  if (failed > 0) return 1;
  return 0;
}

}  // namespace

void add_upgrade(CLI::App& app, Commands& commands) {
  auto o = std::make_shared<Options>();
  auto* command = app.add_subcommand(
      "upgrade", "Rewrite files of older mpmrom versions (variable-length strings) in the current formats, in place");
  add_input(command, "files", o->upgrade_files,
            "Snapshot, model or ROM files you trust (their origin: they are read "
            "with libhdf5's unchecked variable-length strings)");
  command->footer("Example: mpmrom upgrade data/poke/runs/*.h5 poke_model.h5");
  commands.push_back({command, nullptr, [o](const Context& context) { return run(*o, context); }});
}

}  // namespace mpmrom::cli
