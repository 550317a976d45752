// Timings of the solvers, as benchmark records (SPEC.md: device, backend, threads, precision, versions, figures with
// units in their names).
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "fom.hpp"

namespace mpmrom {

struct FomBenchmark {
  std::size_t particles = 0;
  int grid_nodes = 0;
  long steps = 0;
  double seconds = 0;           // wall-clock time of the timed steps, synchronised
  double dt = 0;                // the (CFL) step used
};

// Runs `warmup` untimed steps, then `steps` timed steps of the scene at its CFL time step.
FomBenchmark bench_fom(const Scene& scene, P2GStrategy strategy, long steps, long warmup);

// A benchmark record with the runtime's identity (device, backend, threads, precision, versions) filled in.
nlohmann::json benchmark_record(const std::string& benchmark, const std::string& scene);

}  // namespace mpmrom
