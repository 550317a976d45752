// What one FOM step reports back to the host, gathered on the device into one small View so that the host copies
// it once and waits once per step (each reduction returned to the host would be a wait of its own).
// Parallelism: one thread.
#pragma once

#include "mpm/g2p.hpp"

namespace mpmrom {

enum StepDiagnostic : int {
  step_outside = 0,  // material points whose stencil left the grid (P2G)
  step_not_finite,   // G2P's problem counts
  step_inverted,
  step_max_speed,    // fastest particle after G2P
  step_grid_work,    // work of gravity and boundaries on the grid
  step_force_power,  // power of the external forces
  step_energy,       // on energy-checking steps: kinetic + elastic energy of the state the step started from
  step_box,          // 6 entries: G2P's node box (lo x, y, z, hi x, y, z) of the particles' new stencils
  kNumStepDiagnostics = step_box + 6
};

template <class MemorySpace>
using StepDiagnostics = Kokkos::View<double[kNumStepDiagnostics], MemorySpace>;

template <class ExecutionSpace, class MemorySpace>
void collect_step_diagnostics(const ExecutionSpace& space, const Kokkos::View<int, MemorySpace>& outside,
                              const ParticleProblemCounts<MemorySpace>& problems,
                              const G2PSummaryView<MemorySpace>& g2p_summary,
                              const Kokkos::View<double, MemorySpace>& grid_work,
                              const Kokkos::View<double, MemorySpace>& force_power,
                              const Kokkos::View<double, MemorySpace>& energy,
                              const StepDiagnostics<MemorySpace>& diagnostics) {
  Kokkos::parallel_for(
      "mpmrom::fom::step_diagnostics", Kokkos::RangePolicy<ExecutionSpace>(space, 0, 1), KOKKOS_LAMBDA(const int) {
        diagnostics(step_outside) = outside();
        diagnostics(step_not_finite) = problems(problem_not_finite);
        diagnostics(step_inverted) = problems(problem_inverted);
        diagnostics(step_max_speed) = g2p_summary().max_speed;
        diagnostics(step_grid_work) = grid_work();
        diagnostics(step_force_power) = force_power();
        diagnostics(step_energy) = energy();
        for (int d = 0; d < 3; ++d) {
          diagnostics(step_box + d) = g2p_summary().box.lo[d];
          diagnostics(step_box + 3 + d) = g2p_summary().box.hi[d];
        }
      });
}

}  // namespace mpmrom
