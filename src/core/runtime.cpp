#include "mpmrom/runtime.hpp"

#include <algorithm>
#include <cstdlib>
#include <fstream>

#include "core/kokkos_compat.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom {
namespace {

std::string cpu_model() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) == 0) {
      const auto colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
  }
  return "unknown CPU";
}

std::string device_name() {
#if defined(KOKKOS_ENABLE_CUDA)
  return Kokkos::DefaultExecutionSpace().cuda_device_prop().name;
#else
  return cpu_model();
#endif
}

int gpu_count() {
#if defined(KOKKOS_ENABLE_CUDA)
  return Kokkos::Cuda::detect_device_count();
#else
  return 1;
#endif
}

}  // namespace

KokkosSession::KokkosSession(int threads, int device, int local_rank) {
  // Kokkos' OpenMP backend prints a warning on stdout when OMP_PROC_BIND is unset, which would corrupt --json
  // output; unset means no binding, so say so explicitly.
  setenv("OMP_PROC_BIND", "false", 0);
  if (device < 0 && local_rank > 0 && gpu_count() > 1) device = local_rank % gpu_count();
  compat::initialize(threads, device);
}
KokkosSession::~KokkosSession() { Kokkos::finalize(); }

RuntimeInfo runtime_info() {
  RuntimeInfo info;
  info.backend = Kokkos::DefaultExecutionSpace::name();
  info.threads = compat::concurrency(Kokkos::DefaultHostExecutionSpace());
  info.device = device_name();
  info.kokkos_version = compat::kokkos_version_string();
  info.precision = MPMROM_PRECISION_NAME;
  info.version = MPMROM_VERSION_STRING;
  info.git_commit = git_commit();
  return info;
}

}  // namespace mpmrom
