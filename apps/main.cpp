// mpmrom: the command-line front end. Parsing and printing only; the work is done by the library.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <exception>
#include <iostream>

#include "mpmrom_config.hpp"
#include "runtime.hpp"

namespace {

nlohmann::json to_json(const mpmrom::RuntimeInfo& info) {
  return {{"version", info.version},       {"git_commit", info.git_commit},
          {"backend", info.backend},       {"threads", info.threads},
          {"device", info.device},         {"kokkos_version", info.kokkos_version},
          {"precision", info.precision}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"mpmrom: material point method and its neural reduced-order model, on Kokkos"};
  app.set_version_flag("--version", std::string("mpmrom ") + MPMROM_VERSION_STRING + " (" + mpmrom::git_commit() +
                                        ", " + MPMROM_PRECISION_NAME + ")");
  app.require_subcommand(1);
  int threads = 0;
  int device = -1;
  app.add_option("--threads", threads, "CPU threads for the OpenMP backend (default: OMP_NUM_THREADS or all cores)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--device", device, "GPU index for the CUDA backend (default: 0)")->check(CLI::NonNegativeNumber);

  bool info_json = false;
  auto* info = app.add_subcommand("info", "Print the backend, device, threads and versions this build runs with");
  info->add_flag("--json", info_json, "One JSON object on stdout");
  info->footer("Example: mpmrom info --json");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    mpmrom::KokkosSession kokkos(threads, device);
    if (*info) {
      const auto runtime = mpmrom::runtime_info();
      if (info_json) {
        std::cout << to_json(runtime).dump() << "\n";
      } else {
        std::cout << "mpmrom " << runtime.version << " (" << runtime.git_commit << ")\n"
                  << "  backend:   " << runtime.backend << " (" << runtime.threads << " threads)\n"
                  << "  device:    " << runtime.device << "\n"
                  << "  kokkos:    " << runtime.kokkos_version << "\n"
                  << "  precision: " << runtime.precision << "\n";
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "mpmrom: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
