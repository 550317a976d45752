// The full-order model: explicit MPM on the default Kokkos execution space, driven through the kernels in mpm/.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "mpm/g2p.hpp"
#include "mpm/grid_update.hpp"
#include "mpm/energy.hpp"
#include "mpm/p2g.hpp"
#include "mpm/step_diagnostics.hpp"
#include "mpmrom/scene.hpp"

namespace mpmrom {

// Host copies of the particle fields at one instant, row-major: x, v (n, 3); F, C (n, 3, 3).
struct ParticleFrame {
  double time = 0;
  std::vector<real_t> x, v, F, C;
};

// The scene's background grid (throws beyond 2e9 nodes), its material, and its contact kinds as the kernels name them.
GridGeometry<real_t> grid_for_scene(const Scene& scene);
ElasticMaterial<real_t> material_for_scene(const Scene& scene);
Contact to_contact(ContactKind kind);

// What stopped a full-order run, detected in the step where it happened (docs/stability.md).
enum class FomFailureCause { LeftGrid, NotFinite, Inverted, EnergyBlowUp };
std::string to_string(FomFailureCause cause);

class SimulationFailure : public std::runtime_error {
 public:
  SimulationFailure(FomFailureCause cause, long step, double time, const std::string& detail);
  FomFailureCause cause() const { return cause_; }
  long step() const { return step_; }                    // the step (1-based) that produced the bad state
  double time() const { return time_; }                  // at the start of that step, s
  const std::string& detail() const { return detail_; }  // the message without its "step N (t = ...)" prefix

 private:
  FomFailureCause cause_;
  std::string detail_;
  long step_;
  double time_;
};

// The P2G accumulation a run gets unless it asks: per-thread grid copies summed in a fixed order on host backends
// (bitwise reproducible for a given thread count, and the faster one on a few cores; they cost threads x grid
// memory), atomics on devices (faster there than scratch-memory tiles on the lattice-ordered cylinders measured).
P2GStrategy default_p2g_strategy();

// How the FOM stores its material points: in the scene's sampling order (a lattice body line by line along z), or
// brick by brick (4^3 cells; inside a brick the first point of every cell, then the second, ...), which keeps
// a GPU team's particles inside one brick's nodes. Outputs are in sampling order either way.
enum class ParticleOrder { Sampling, Bricks };
ParticleOrder default_particle_order();

class FomSolver {
 public:
  using ExecutionSpace = Kokkos::DefaultExecutionSpace;
  using MemorySpace = ExecutionSpace::memory_space;

  explicit FomSolver(const Scene& scene, P2GStrategy strategy = default_p2g_strategy(),
                     const P2GTiling& tiling = default_p2g_tiling<Kokkos::DefaultExecutionSpace>(),
                     ParticleOrder order = default_particle_order());

  double time() const { return time_; }
  long steps() const { return steps_; }
  std::size_t num_particles() const { return particles_.size(); }
  const GridGeometry<real_t>& grid() const { return grid_; }
  // The fields in storage order: point s of these Views is point sample_index(s) of the scene. Positions set between
  // steps must stay within the nodes the last step's positions reach (a point that leaves them stops the next step).
  const ParticleViews<MemorySpace>& particles() const { return particles_; }
  std::size_t sample_index(std::size_t s) const { return sample_of_slot_[s]; }
  const GridNodeView<MemorySpace>& grid_nodes() const { return nodes_; }

  // The CFL-limited time step: cfl * dx / (P-wave speed + fastest particle).
  double stable_time_step() const;
  // One explicit step of length dt. Throws SimulationFailure when a material point leaves the grid, a field stops
  // being finite, a deformation gradient inverts (det F <= 0) or the energy exceeds its budget.
  void step(double dt);
  // Equal steps that land exactly on `target_time`: no longer than the CFL step (or the scene's fixed dt), and than
  // the max_cfl safeguard allows. Checks the energy budget at the end.
  void advance_to(double target_time);

  // Kinetic + elastic energy now, and the budget it is held to: initial energy plus the positive work put in by
  // external forces, gravity and moving boundaries (a stable run stays below it, up to the transfers' small errors).
  ParticleEnergy energy() const;
  double energy_budget() const { return initial_energy_ + work_in_; }
  // The last periodic energy check: the state's step count and its energy (step -1 before the first).
  struct EnergyCheck {
    long step = -1;
    double energy = 0;
  };
  EnergyCheck last_energy_check() const { return last_energy_check_; }
  // Steps the max_cfl safeguard shortened.
  long safeguarded_steps() const { return safeguarded_steps_; }

  // Reference configuration (host, row-major) and the current fields.
  void reference(std::vector<real_t>& X, std::vector<real_t>& mass, std::vector<real_t>& volume) const;
  ParticleFrame frame() const;

 private:
  // Throws SimulationFailure (energy blow-up) when the energy exceeds energy_growth times the budget.
  void check_energy(long step, double dt) const;
  void enforce_energy_budget(double energy, double budget, long step, double time, double dt) const;

  Scene scene_;
  P2GStrategy strategy_;
  P2GTiling tiling_;
  GridGeometry<real_t> grid_;
  ElasticMaterial<real_t> material_;
  real_t wave_speed_;
  ParticleViews<MemorySpace> particles_;
  GridNodeView<MemorySpace> nodes_;
  GridCopies<ExecutionSpace> copies_;  // host backends' scatter strategy
  // The nodes the next step prepares (the whole grid until a step has run: callers may set the first state through
  // particles()), and those the last step left non-zero.
  NodeBox reach_, written_ = NodeBox::none();
  std::vector<std::size_t> sample_of_slot_;
  Kokkos::View<int, MemorySpace> outside_;
  ParticleProblemCounts<MemorySpace> problems_;
  // Each step's reductions land on the device and come back in one copy, so the host waits once per step.
  G2PSummaryView<MemorySpace> step_g2p_;
  Kokkos::View<double, MemorySpace> step_grid_work_, step_force_power_, step_energy_;
  // The periodic energy check rides on the next step's P2G, which computes each point's polar rotation anyway: V_p
  // Psi(F_p).
  bool energy_check_due_ = false;
  Kokkos::View<double*, MemorySpace> elastic_energy_;
  StepDiagnostics<MemorySpace> step_diagnostics_;
  StepDiagnostics<Kokkos::HostSpace> step_diagnostics_host_;
  double total_mass_ = 0;
  double initial_energy_ = 0, work_in_ = 0;
  long safeguarded_steps_ = 0;
  EnergyCheck last_energy_check_;
  double time_ = 0;
  long steps_ = 0;
  real_t max_speed_ = 0;
};

}  // namespace mpmrom
