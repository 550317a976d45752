// mpmrom info: the backend, device, threads and versions of this build.
#include <iostream>
#include <memory>

#include "command.hpp"
#include "common.hpp"

namespace mpmrom::cli {

void add_info(CLI::App& app, Commands& commands) {
  auto json = std::make_shared<bool>(false);
  auto* info = app.add_subcommand("info", "Print the backend, device, threads and versions this build runs with");
  info->add_flag("--json", *json, "One JSON object on stdout");
  info->footer("Example: mpmrom info --json");
  commands.push_back({info, nullptr, [json](const Context&) {
                        const auto runtime = runtime_info();
                        if (*json) {
                          std::cout << to_json(runtime).dump() << "\n";
                        } else {
                          std::cout << "mpmrom " << runtime.version << " (" << runtime.git_commit << ")\n"
                                    << "  backend:   " << runtime.backend << " (" << runtime.threads << " threads)\n"
                                    << "  device:    " << runtime.device << "\n"
                                    << "  kokkos:    " << runtime.kokkos_version << "\n"
                                    << "  precision: " << runtime.precision << "\n";
                        }
                        return 0;
                      }});
}

}  // namespace mpmrom::cli
