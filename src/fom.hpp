// The full-order model: explicit MPM on the default Kokkos execution space, driven through the kernels in kernels/.
#pragma once

#include <string>
#include <vector>

#include "kernels/g2p.hpp"
#include "kernels/grid_update.hpp"
#include "kernels/p2g.hpp"
#include "scene.hpp"

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

class FomSolver {
 public:
  using ExecutionSpace = Kokkos::DefaultExecutionSpace;
  using MemorySpace = ExecutionSpace::memory_space;

  explicit FomSolver(const Scene& scene, P2GStrategy strategy = P2GStrategy::Atomic);

  double time() const { return time_; }
  long steps() const { return steps_; }
  std::size_t num_particles() const { return particles_.size(); }
  const GridGeometry<real_t>& grid() const { return grid_; }
  const ParticleViews<MemorySpace>& particles() const { return particles_; }
  const GridNodeView<MemorySpace>& grid_nodes() const { return nodes_; }

  // The CFL-limited time step: cfl * dx / (P-wave speed + fastest particle).
  double stable_time_step() const;
  // One explicit step of length dt. Throws if a material point leaves the grid.
  void step(double dt);
  // Sub-steps under the CFL limit so that the last one lands exactly on `target_time`.
  void advance_to(double target_time);

  // Reference configuration (host, row-major) and the current fields.
  void reference(std::vector<real_t>& X, std::vector<real_t>& mass, std::vector<real_t>& volume) const;
  ParticleFrame frame() const;

 private:
  Scene scene_;
  P2GStrategy strategy_;
  GridGeometry<real_t> grid_;
  ElasticMaterial<real_t> material_;
  real_t wave_speed_;
  ParticleViews<MemorySpace> particles_;
  GridNodeView<MemorySpace> nodes_;
  GridScatterView<ExecutionSpace, MemorySpace> scatter_;
  Kokkos::View<int, MemorySpace> outside_;
  double time_ = 0;
  long steps_ = 0;
  real_t max_speed_ = 0;
};

}  // namespace mpmrom
