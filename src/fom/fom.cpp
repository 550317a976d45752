#include "fom/fom.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>

#include "scene/sampling.hpp"

namespace mpmrom {

std::string to_string(FomFailureCause cause) {
  switch (cause) {
    case FomFailureCause::LeftGrid: return "left the grid";
    case FomFailureCause::NotFinite: return "not finite";
    case FomFailureCause::Inverted: return "inverted";
    case FomFailureCause::EnergyBlowUp: return "energy blow-up";
  }
  return "";
}

SimulationFailure::SimulationFailure(FomFailureCause cause, long step, double time, const std::string& detail)
    : std::runtime_error("step " + std::to_string(step) + " (t = " + std::to_string(time) + " s): " + detail),
      cause_(cause),
      detail_(detail),
      step_(step),
      time_(time) {}

Contact to_contact(ContactKind kind) {
  switch (kind) {
    case ContactKind::Sticky: return Contact::Sticky;
    case ContactKind::Slip: return Contact::Slip;
    case ContactKind::Separate: return Contact::Separate;
  }
  return Contact::Separate;
}

GridGeometry<real_t> grid_for_scene(const Scene& scene) {
  GridGeometry<real_t> grid;
  grid.dx = static_cast<real_t>(scene.dx);
  grid.inv_dx = static_cast<real_t>(1 / scene.dx);
  // Counted in doubles first: an axis of more than 2^31 cells must be refused, not converted to int.
  double nodes = 1, dims[3];
  for (int d = 0; d < 3; ++d) {
    dims[d] = std::ceil((scene.domain.hi[d] - scene.domain.lo[d]) / scene.dx - 1e-9) + 1;
    nodes *= dims[d];
  }
  if (nodes > 2e9) throw std::runtime_error("the grid would have more than 2e9 nodes; enlarge dx or shrink the domain");
  for (int d = 0; d < 3; ++d) {
    grid.origin[d] = static_cast<real_t>(scene.domain.lo[d]);
    grid.dims[d] = static_cast<int>(dims[d]);
  }
  return grid;
}

ElasticMaterial<real_t> material_for_scene(const Scene& scene) {
  return elastic_material<real_t>(
      scene.material.model == ElasticModelKind::NeoHookean ? ElasticModel::NeoHookean : ElasticModel::FixedCorotated,
      static_cast<real_t>(scene.material.youngs_modulus), static_cast<real_t>(scene.material.poisson_ratio));
}

P2GStrategy default_p2g_strategy() {
  return Kokkos::SpaceAccessibility<Kokkos::HostSpace, FomSolver::MemorySpace>::accessible ? P2GStrategy::Scatter
                                                                                           : P2GStrategy::Atomic;
}

namespace {

// Sample indices in storage order: brick by brick (4^3 cells, bricks in grid order); inside a brick, the first point
// of each of its cells, then the second of each, and so on. A GPU team's particles then share a brick's 6^3 nodes,
// and the 32 threads of a warp sit in 32 different cells, so no two of them add to the same node at once.
// Stable in sampling order, so the order is the same on every machine.
std::vector<std::size_t> brick_order(const std::vector<double>& X, const GridGeometry<real_t>& grid) {
  constexpr int kBrick = 4, kCellsPerBrick = kBrick * kBrick * kBrick;
  const std::size_t n = X.size() / 3;
  int bricks[3];
  for (int d = 0; d < 3; ++d) bricks[d] = (grid.dims[d] + kBrick - 1) / kBrick;
  std::vector<std::uint64_t> brick(n), cell(n), rank(n, 0);
  for (std::size_t p = 0; p < n; ++p) {
    int b[3], c[3];
    for (int d = 0; d < 3; ++d) {
      const double at = std::floor((X[3 * p + d] - double(grid.origin[d])) / double(grid.dx));
      const int clamped = static_cast<int>(std::min(std::max(at, 0.0), double(grid.dims[d] - 1)));
      b[d] = clamped / kBrick;
      c[d] = clamped % kBrick;
    }
    brick[p] = (std::uint64_t(b[0]) * bricks[1] + b[1]) * bricks[2] + b[2];
    cell[p] = (c[0] * kBrick + c[1]) * kBrick + c[2];
  }
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t(0));
  const auto by_cell = [&](std::size_t a, std::size_t b) {
    return brick[a] * kCellsPerBrick + cell[a] < brick[b] * kCellsPerBrick + cell[b];
  };
  std::stable_sort(order.begin(), order.end(), by_cell);
  for (std::size_t i = 1; i < n; ++i)  // each point's rank among the points of its cell
    if (!by_cell(order[i - 1], order[i])) rank[order[i]] = rank[order[i - 1]] + 1;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    if (brick[a] != brick[b]) return brick[a] < brick[b];
    if (rank[a] != rank[b]) return rank[a] < rank[b];
    return cell[a] < cell[b];
  });
  return order;
}

}  // namespace

// Lattice bodies come line by line along z, which is what GPU atomics like best (perf/README.md: bricks were slower).
ParticleOrder default_particle_order() { return ParticleOrder::Sampling; }

FomSolver::FomSolver(const Scene& scene, P2GStrategy strategy, const P2GTiling& tiling, ParticleOrder order)
    : scene_(scene),
      strategy_(strategy),
      tiling_(tiling),
      grid_(grid_for_scene(scene)),
      material_(material_for_scene(scene)),
      wave_speed_(stable_time_step_wave_speed(material_, static_cast<real_t>(scene.material.density))),
      outside_("mpmrom::fom::outside"),
      problems_("mpmrom::fom::problems"),
      step_g2p_("mpmrom::fom::step_g2p"),
      step_grid_work_("mpmrom::fom::step_grid_work"),
      step_force_power_("mpmrom::fom::step_force_power"),
      step_energy_("mpmrom::fom::step_energy"),
      step_diagnostics_("mpmrom::fom::step_diagnostics"),
      step_diagnostics_host_("mpmrom::fom::step_diagnostics_host") {
  if (tiling.team_size < 1 || tiling.particles_per_team < 1 || tiling.max_tile_nodes < 27)
    throw std::runtime_error("P2G tiles need at least one thread and one particle per team and room for 27 nodes");
  if (scene.forces.size() > static_cast<std::size_t>(kMaxExternalForces))
    throw std::runtime_error("at most " + std::to_string(kMaxExternalForces) + " [[force]] entries are supported");
  if (scene.dirichlet.size() > static_cast<std::size_t>(kMaxDirichletRegions))
    throw std::runtime_error("at most " + std::to_string(kMaxDirichletRegions) +
                             " [[dirichlet]] entries are supported");

  const ParticleSamples samples = sample_scene(scene);
  const std::size_t n = samples.size();
  if (order == ParticleOrder::Bricks) {
    sample_of_slot_ = brick_order(samples.X, grid_);
  } else {
    sample_of_slot_.resize(n);
    std::iota(sample_of_slot_.begin(), sample_of_slot_.end(), std::size_t(0));
  }
  const int num_forces = static_cast<int>(scene.forces.size());
  particles_ = ParticleViews<MemorySpace>(n, num_forces);
  nodes_ = GridNodeView<MemorySpace>("mpmrom::fom::grid_nodes", grid_.num_nodes());
  reach_ = NodeBox::whole(grid_);
  if (strategy_ == P2GStrategy::Scatter) copies_ = GridCopies<ExecutionSpace>(grid_.num_nodes());

  auto X = Kokkos::create_mirror_view(particles_.X);
  auto v = Kokkos::create_mirror_view(particles_.v);
  auto F = Kokkos::create_mirror_view(particles_.F);
  auto C = Kokkos::create_mirror_view(particles_.C);
  auto mass = Kokkos::create_mirror_view(particles_.mass);
  auto volume = Kokkos::create_mirror_view(particles_.volume);
  auto share = Kokkos::create_mirror_view(particles_.force_share);
  for (std::size_t p = 0; p < n; ++p) {  // p: storage slot, q: the sample stored there
    const std::size_t q = sample_of_slot_[p];
    const Vec3d& w = scene.bodies[samples.body[q]].angular_velocity;
    // A rigid spin v = w x r has velocity gradient [w]_x, which APIC carries in C from the start.
    const double spin[3][3] = {{0, -w[2], w[1]}, {w[2], 0, -w[0]}, {-w[1], w[0], 0}};
    for (int i = 0; i < 3; ++i) {
      X(p, i) = static_cast<real_t>(samples.X[3 * q + i]);
      v(p, i) = static_cast<real_t>(samples.velocity[3 * q + i]);
      for (int j = 0; j < 3; ++j) {
        F(p, i, j) = i == j ? real_t(1) : real_t(0);
        C(p, i, j) = scene.transfer == TransferKind::APIC ? static_cast<real_t>(spin[i][j]) : real_t(0);
      }
    }
    mass(p) = static_cast<real_t>(samples.mass[q]);
    volume(p) = static_cast<real_t>(samples.volume[q]);
  }
  for (int k = 0; k < num_forces; ++k) {
    double region_mass = 0;
    for (std::size_t p = 0; p < n; ++p)
      if (scene.forces[k].region.contains({samples.X[3 * p], samples.X[3 * p + 1], samples.X[3 * p + 2]}))
        region_mass += samples.mass[p];
    if (region_mass <= 0)
      throw std::runtime_error("[[force]] " + std::to_string(k + 1) +
                               " acts on no material point: its region is empty");
    for (std::size_t slot = 0; slot < n; ++slot) {
      const std::size_t q = sample_of_slot_[slot];
      const bool inside =
          scene.forces[k].region.contains({samples.X[3 * q], samples.X[3 * q + 1], samples.X[3 * q + 2]});
      share(slot, k) = inside ? static_cast<real_t>(samples.mass[q] / region_mass) : real_t(0);
    }
  }
  Kokkos::deep_copy(particles_.X, X);
  Kokkos::deep_copy(particles_.x, X);
  Kokkos::deep_copy(particles_.v, v);
  Kokkos::deep_copy(particles_.F, F);
  Kokkos::deep_copy(particles_.C, C);
  Kokkos::deep_copy(particles_.mass, mass);
  Kokkos::deep_copy(particles_.volume, volume);
  Kokkos::deep_copy(particles_.force_share, share);

  real_t speed = 0;
  for (std::size_t p = 0; p < n; ++p) {
    speed = std::max(speed, static_cast<real_t>(std::sqrt(v(p, 0) * v(p, 0) + v(p, 1) * v(p, 1) + v(p, 2) * v(p, 2))));
    total_mass_ += samples.mass[sample_of_slot_[p]];
  }
  max_speed_ = speed;
  initial_energy_ = energy().total();
}

ParticleEnergy FomSolver::energy() const { return particle_energy(ExecutionSpace(), particles_, material_); }

double FomSolver::stable_time_step() const { return scene_.cfl * scene_.dx / (wave_speed_ + max_speed_); }

void FomSolver::step(double dt) {
  const ExecutionSpace space;
  // The budget starts from the state the first step sees: callers may set initial fields through particles().
  if (steps_ == 0) initial_energy_ = energy().total();
  ExternalForces external;
  for (const auto& f : scene_.forces) {
    const bool active = time_ >= f.start && time_ < f.end;
    for (int d = 0; d < 3; ++d) external.force[3 * external.count + d] = active ? static_cast<real_t>(f.force[d]) : 0;
    ++external.count;
  }
  GridBoundary boundary;
  boundary.walls = to_contact(scene_.walls);
  boundary.ground = scene_.ground.enabled;
  boundary.ground_height = static_cast<real_t>(scene_.ground.height);
  boundary.ground_contact = to_contact(scene_.ground.contact);
  for (const auto& region : scene_.dirichlet) {
    if (!(time_ >= region.start && time_ < region.end)) continue;
    const int r = boundary.num_dirichlet++;
    for (int d = 0; d < 3; ++d) {
      boundary.dirichlet_box[6 * r + d] = static_cast<real_t>(region.region.lo[d]);
      boundary.dirichlet_box[6 * r + 3 + d] = static_cast<real_t>(region.region.hi[d]);
      boundary.dirichlet_velocity[3 * r + d] = static_cast<real_t>(region.velocity[d]);
    }
  }
  const Vec3<real_t> gravity{{static_cast<real_t>(scene_.gravity[0]), static_cast<real_t>(scene_.gravity[1]),
                              static_cast<real_t>(scene_.gravity[2])}};
  const bool apic = scene_.transfer == TransferKind::APIC;
  // A due energy check looks at the state this step starts from, whose elastic energy P2G computes on the way.
  const bool checking = energy_check_due_;
  const double budget = energy_budget();
  if (checking && elastic_energy_.extent(0) != particles_.size())
    elastic_energy_ = Kokkos::View<double*, MemorySpace>("mpmrom::fom::elastic_energy", particles_.size());
  using EnergyView = Kokkos::View<double*, MemorySpace>;
  const EnergyView energy_out = checking ? elastic_energy_ : EnergyView();
  const P2GParticle<MemorySpace> kernel{particles_, grid_,    material_,  external, static_cast<real_t>(dt),
                                        apic,       outside_, energy_out, reach_};

  // Every pass over the grid covers only the nodes the particles' stencils reach; the others stay zero.
  zero_box(space, nodes_, written_, grid_);
  written_ = reach_;
  switch (strategy_) {
    case P2GStrategy::Atomic: p2g_atomic(space, kernel, nodes_); break;
    case P2GStrategy::Scatter: p2g_scatter(space, kernel, copies_, nodes_); break;
    case P2GStrategy::Tiled: p2g_tiled(space, kernel, nodes_, tiling_); break;
  }
  if (checking) particle_energy_total(space, particles_, elastic_energy_, step_energy_);  // before G2P moves v
  grid_update(space, nodes_, grid_, reach_, gravity, boundary, static_cast<real_t>(dt), step_grid_work_);
  g2p(space, particles_, nodes_, grid_, static_cast<real_t>(dt), apic, problems_, step_g2p_);
  external_force_power(space, particles_, external, step_force_power_);
  collect_step_diagnostics(space, outside_, problems_, step_g2p_, step_grid_work_, step_force_power_, step_energy_,
                           step_diagnostics_);
  Kokkos::deep_copy(step_diagnostics_host_, step_diagnostics_);  // the step's one wait
  const auto& diagnostics = step_diagnostics_host_;
  max_speed_ = static_cast<real_t>(diagnostics(step_max_speed));
  NodeBox reached;
  for (int d = 0; d < 3; ++d) {
    reached.lo[d] = static_cast<int>(diagnostics(step_box + d));
    reached.hi[d] = static_cast<int>(diagnostics(step_box + 3 + d));
  }
  // One node of margin: P2G's vectorised blocks may round a point's first stencil node differently from G2P.
  reach_ = padded(reached, 1, grid_);
  const double grid_work = diagnostics(step_grid_work), force_work = dt * diagnostics(step_force_power);

  const auto fail = [&](FomFailureCause cause, const std::string& detail) {
    throw SimulationFailure(cause, steps_ + 1, time_, detail);
  };
  const auto count = [&](StepDiagnostic which) { return static_cast<long>(diagnostics(which)); };
  if (checking) {  // the state before this step, against the budget it had
    energy_check_due_ = false;
    last_energy_check_ = {steps_, diagnostics(step_energy)};
    enforce_energy_budget(diagnostics(step_energy), budget, steps_, time_, 0);
  }
  if (count(step_outside) > 0)
    fail(FomFailureCause::LeftGrid,
         std::to_string(count(step_outside)) + " material points left the grid; enlarge [grid] lo/hi");
  const auto too_long = [dt]() { return " (a step of " + std::to_string(dt) + " s; lower [time] cfl or set max_cfl)"; };
  if (count(step_not_finite) > 0)
    fail(FomFailureCause::NotFinite, std::to_string(count(step_not_finite)) +
                                         " material points have a non-finite velocity, position or det F" + too_long());
  if (count(step_inverted) > 0)
    fail(FomFailureCause::Inverted,
         std::to_string(count(step_inverted)) + " material points inverted (det F <= 0)" + too_long());
  // Only work put in counts: the budget must not shrink when the boundaries take energy out.
  work_in_ += std::max(0.0, grid_work + force_work);
  // Every 16 steps, and after any step where the fastest point could carry more kinetic energy than the limit (a
  // loose bound: early in a run from rest it holds for many steps): checked by the next step's P2G.
  const double kinetic_bound = 0.5 * total_mass_ * double(max_speed_) * double(max_speed_);
  if (scene_.energy_growth > 0 && ((steps_ + 1) % 16 == 0 || kinetic_bound > scene_.energy_growth * energy_budget()))
    energy_check_due_ = true;
  time_ += dt;
  ++steps_;
}

void FomSolver::advance_to(double target_time) {
  while (time_ < target_time) {
    const double remaining = target_time - time_;
    double dt_max = scene_.time_step > 0 ? scene_.time_step : stable_time_step();
    if (scene_.max_cfl > 0) {
      const double safe = scene_.max_cfl * scene_.dx / (wave_speed_ + max_speed_);
      if (safe < dt_max) {
        dt_max = safe;
        ++safeguarded_steps_;
      }
    }
    // Equal sub-steps that land on target_time, none longer than dt_max.
    const double substeps = std::ceil(remaining / dt_max - 1e-9);
    const double dt = substeps <= 1 ? remaining : remaining / substeps;
    step(dt);
    if (substeps <= 1) time_ = target_time;
  }
  check_energy(steps_, 0);  // callers write this state: it is checked now
  energy_check_due_ = false;
}

void FomSolver::check_energy(long step, double dt) const {
  if (scene_.energy_growth > 0) enforce_energy_budget(energy().total(), energy_budget(), step, time_, dt);
}

void FomSolver::enforce_energy_budget(double energy, double budget, long step, double time, double dt) const {
  if (!(scene_.energy_growth > 0)) return;
  // The floor is the round-off scale: a run at rest under no load has zero energy and a zero budget.
  const double floor = 1e-12 * total_mass_ * double(wave_speed_) * double(wave_speed_);
  if (energy > scene_.energy_growth * budget + floor)
    throw SimulationFailure(FomFailureCause::EnergyBlowUp, step, time,
                            "the energy " + std::to_string(energy) + " J exceeds " +
                                std::to_string(scene_.energy_growth) +
                                " times the initial energy plus the work put in (" + std::to_string(budget) + " J)" +
                                (dt > 0 ? " after a step of " + std::to_string(dt) + " s" : std::string()) +
                                "; lower [time] cfl or set max_cfl");
}

void FomSolver::reference(std::vector<real_t>& X, std::vector<real_t>& mass, std::vector<real_t>& volume) const {
  const std::size_t n = num_particles();
  auto hX = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), particles_.X);
  auto hm = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), particles_.mass);
  auto hV = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), particles_.volume);
  X.resize(3 * n);
  mass.resize(n);
  volume.resize(n);
  for (std::size_t slot = 0; slot < n; ++slot) {
    const std::size_t p = sample_of_slot_[slot];
    for (int d = 0; d < 3; ++d) X[3 * p + d] = hX(slot, d);
    mass[p] = hm(slot);
    volume[p] = hV(slot);
  }
}

ParticleFrame FomSolver::frame() const {
  const std::size_t n = num_particles();
  ParticleFrame f;
  f.time = time_;
  auto hx = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), particles_.x);
  auto hv = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), particles_.v);
  auto hF = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), particles_.F);
  auto hC = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), particles_.C);
  f.x.resize(3 * n);
  f.v.resize(3 * n);
  f.F.resize(9 * n);
  f.C.resize(9 * n);
  for (std::size_t slot = 0; slot < n; ++slot) {
    const std::size_t p = sample_of_slot_[slot];
    for (int i = 0; i < 3; ++i) {
      f.x[3 * p + i] = hx(slot, i);
      f.v[3 * p + i] = hv(slot, i);
      for (int j = 0; j < 3; ++j) {
        f.F[9 * p + 3 * i + j] = hF(slot, i, j);
        f.C[9 * p + 3 * i + j] = hC(slot, i, j);
      }
    }
  }
  return f;
}

}  // namespace mpmrom
