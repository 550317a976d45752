#include "core/benchmark_record.hpp"

#include "mpmrom/runtime.hpp"

namespace mpmrom {

nlohmann::json benchmark_record(const std::string& benchmark, const std::string& scene) {
  const RuntimeInfo info = runtime_info();
  return {{"benchmark", benchmark},
          {"scene", scene},
          {"device", info.device},
          {"backend", info.backend},
          {"threads", info.threads},
          {"precision", info.precision},
          {"kokkos_version", info.kokkos_version},
          {"mpmrom_version", info.version},
          {"git_commit", info.git_commit}};
}

}  // namespace mpmrom
