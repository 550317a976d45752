// What a scene gives the reduced model's kernels: each rollout's loads, the reference domain of Algorithm 2 and the
// horizon (rom/detail/rom_stepper.hpp).
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "core/checked_integer.hpp"
#include "rom/detail/rollout_driver.hpp"

namespace mpmrom {

void impl::apply_horizon(Scene& scene, double end_time) {
  const double interval = scene.end_time / scene.num_outputs;
  const auto name = [] { return std::string("--end-time, in output intervals of the scene,"); };
  scene.num_outputs = impl::checked_integer<int>(std::max(1.0, std::round(end_time / interval)), name, 1);
  scene.end_time = scene.num_outputs * interval;  // a whole number of the scene's output intervals
}

rom::RolloutLoads impl::loads_for_scene(const Scene& scene, const ReferencePoints& model) {
  rom::RolloutLoads loads;
  if (scene.forces.size() > std::size_t(kMaxExternalForces))
    throw std::runtime_error("at most " + std::to_string(kMaxExternalForces) + " [[force]] entries are supported");
  if (scene.dirichlet.size() > std::size_t(kMaxDirichletRegions))
    throw std::runtime_error("at most " + std::to_string(kMaxDirichletRegions) +
                             " [[dirichlet]] entries are supported");
  for (const auto& f : scene.forces) {
    double region_mass = 0;
    for (std::size_t p = 0; p < model.mass.size(); ++p)
      if (f.region.contains({model.X[3 * p], model.X[3 * p + 1], model.X[3 * p + 2]})) region_mass += model.mass[p];
    if (!(region_mass > 0)) throw std::runtime_error("a [[force]] region holds none of the model's material points");
    const int k = loads.num_forces++;
    for (int d = 0; d < 3; ++d) {
      loads.force_per_mass[3 * k + d] = real_t(f.force[d] / region_mass);
      loads.force_box[6 * k + d] = real_t(f.region.lo[d]);
      loads.force_box[6 * k + 3 + d] = real_t(f.region.hi[d]);
    }
    loads.force_window[2 * k] = real_t(f.start);
    loads.force_window[2 * k + 1] = real_t(std::min(f.end, 1e30));
  }
  GridBoundary& boundary = loads.boundary;
  boundary.walls = to_contact(scene.walls);
  boundary.ground = scene.ground.enabled;
  boundary.ground_height = real_t(scene.ground.height);
  boundary.ground_contact = to_contact(scene.ground.contact);
  for (const auto& region : scene.dirichlet) {
    const int r = boundary.num_dirichlet++;
    for (int d = 0; d < 3; ++d) {
      boundary.dirichlet_box[6 * r + d] = real_t(region.region.lo[d]);
      boundary.dirichlet_box[6 * r + 3 + d] = real_t(region.region.hi[d]);
      boundary.dirichlet_velocity[3 * r + d] = real_t(region.velocity[d]);
    }
    loads.dirichlet_window[2 * r] = real_t(region.start);
    loads.dirichlet_window[2 * r + 1] = real_t(std::min(region.end, 1e30));
  }
  for (int d = 0; d < 3; ++d) loads.gravity[d] = real_t(scene.gravity[d]);
  return loads;
}

rom::ReferenceDomain impl::reference_domain(const Scene& scene) {
  rom::ReferenceDomain domain;
  if (scene.bodies.size() > std::size_t(rom::max_reference_bodies))
    throw std::runtime_error("the sample-node ROM supports at most " + std::to_string(rom::max_reference_bodies) +
                             " bodies");
  for (const auto& body : scene.bodies) {
    const int b = domain.num_bodies++;
    domain.shape[b] = body.shape == ShapeKind::Box        ? rom::ReferenceDomain::Box
                      : body.shape == ShapeKind::Cylinder ? rom::ReferenceDomain::Cylinder
                                                          : rom::ReferenceDomain::Sphere;
    for (int d = 0; d < 3; ++d) {
      domain.center[3 * b + d] = real_t(body.center[d]);
      domain.half_extents[3 * b + d] = real_t(body.half_extents[d]);
    }
    domain.radius[b] = real_t(body.radius);
    domain.half_height[b] = real_t(body.height / 2);
  }
  return domain;
}

}  // namespace mpmrom
