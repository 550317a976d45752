// P2G then G2P: conservation of mass, linear and angular momentum, and exact reproduction of affine velocity fields,
// for every accumulation strategy (atomic, scatter, tiles), on every backend.
#include <algorithm>
#include <cmath>

#include "backends.hpp"
#include "mpm/g2p.hpp"
#include "mpm/grid_update.hpp"
#include "mpm/p2g.hpp"

namespace mpmrom::test {
namespace {

struct Totals {
  double mass = 0;
  double momentum[3] = {0, 0, 0};
  double angular[3] = {0, 0, 0};
};

// Particle totals. With APIC the affine part carries angular momentum m (dx^2 / 4) eps_abc C_cb (Jiang et al. 2015),
// since sum_i w_ip (x_i - x_p)(x_i - x_p)^T = (dx^2 / 4) I for quadratic B-splines.
template <class Vectors, class Matrices, class Scalars>
Totals particle_totals(const Vectors& x, const Vectors& v, const Matrices& C, const Scalars& mass, double dx,
                       bool apic) {
  Totals t;
  const double inertia = dx * dx / 4;
  for (std::size_t p = 0; p < mass.extent(0); ++p) {
    const double m = mass(p);
    t.mass += m;
    for (int a = 0; a < 3; ++a) t.momentum[a] += m * v(p, a);
    const int b[3] = {1, 2, 0}, c[3] = {2, 0, 1};
    for (int a = 0; a < 3; ++a) {
      t.angular[a] += m * (x(p, b[a]) * v(p, c[a]) - x(p, c[a]) * v(p, b[a]));
      if (apic) t.angular[a] += m * inertia * (C(p, c[a], b[a]) - C(p, b[a], c[a]));
    }
  }
  return t;
}

// Grid totals; `velocity` says whether columns 1-3 hold velocities (after the update) or momenta (after P2G).
template <class Nodes>
Totals grid_totals(const Nodes& nodes, const GridGeometry<real_t>& grid, bool velocity) {
  Totals t;
  for (int node = 0; node < grid.num_nodes(); ++node) {
    const double m = nodes(node, 0);
    if (m <= 0) continue;
    int i, j, k;
    grid.indices(node, i, j, k);
    const auto x = grid.position(i, j, k);
    double mv[3];
    for (int d = 0; d < 3; ++d) mv[d] = velocity ? m * nodes(node, d + 1) : double(nodes(node, d + 1));
    t.mass += m;
    for (int d = 0; d < 3; ++d) t.momentum[d] += mv[d];
    t.angular[0] += x[1] * mv[2] - x[2] * mv[1];
    t.angular[1] += x[2] * mv[0] - x[0] * mv[2];
    t.angular[2] += x[0] * mv[1] - x[1] * mv[0];
  }
  return t;
}

void expect_totals_near(const Totals& a, const Totals& b, double tol_mass, double tol_momentum, double tol_angular,
                        bool check_angular, const char* what) {
  EXPECT_NEAR(a.mass, b.mass, tol_mass) << what;
  for (int d = 0; d < 3; ++d) {
    EXPECT_NEAR(a.momentum[d], b.momentum[d], tol_momentum) << what << ", momentum " << d;
    if (check_angular) EXPECT_NEAR(a.angular[d], b.angular[d], tol_angular) << what << ", angular momentum " << d;
  }
}

template <class ExecutionSpace>
struct TransferSetup {
  using MemorySpace = typename ExecutionSpace::memory_space;
  GridGeometry<real_t> grid;
  ParticleViews<MemorySpace> particles;
  GridNodeView<MemorySpace> nodes;
  Kokkos::View<int, MemorySpace> outside{"outside"};
  ParticleProblemCounts<MemorySpace> problems{"problems"};

  // n particles scattered in the middle of a 16^3-node grid, away from the wall zones; velocities v = A x + b + noise.
  TransferSetup(int n, const double A[3][3], const double b[3], double noise, unsigned seed) {
    grid.dx = real_t(0.125);
    grid.inv_dx = real_t(8);
    for (int d = 0; d < 3; ++d) {
      grid.origin[d] = real_t(-1);
      grid.dims[d] = 17;
    }
    particles = ParticleViews<MemorySpace>(n, 0);
    nodes = GridNodeView<MemorySpace>("nodes", grid.num_nodes());
    auto x = Kokkos::create_mirror_view(particles.x);
    auto v = Kokkos::create_mirror_view(particles.v);
    auto C = Kokkos::create_mirror_view(particles.C);
    auto F = Kokkos::create_mirror_view(particles.F);
    auto m = Kokkos::create_mirror_view(particles.mass);
    auto vol = Kokkos::create_mirror_view(particles.volume);
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1);
    for (int p = 0; p < n; ++p) {
      for (int d = 0; d < 3; ++d) x(p, d) = real_t(0.45 * u(rng));
      for (int d = 0; d < 3; ++d) {
        v(p, d) = real_t(b[d] + A[d][0] * x(p, 0) + A[d][1] * x(p, 1) + A[d][2] * x(p, 2) + noise * u(rng));
        for (int e = 0; e < 3; ++e) {
          C(p, d, e) = real_t(A[d][e] + noise * u(rng));
          F(p, d, e) = d == e ? 1 : 0;
        }
      }
      m(p) = real_t(1 + 0.5 * u(rng));
      vol(p) = real_t(1e-3);
    }
    Kokkos::deep_copy(particles.x, x);
    Kokkos::deep_copy(particles.v, v);
    Kokkos::deep_copy(particles.C, C);
    Kokkos::deep_copy(particles.F, F);
    Kokkos::deep_copy(particles.mass, m);
    Kokkos::deep_copy(particles.volume, vol);
  }

  // P2G with dt = 0 (no forces), then the grid update with dt = 0 (momentum to velocity).
  void p2g(P2GStrategy strategy, bool apic, const P2GTiling& tiling = default_p2g_tiling<ExecutionSpace>()) {
    const ExecutionSpace space;
    const P2GParticle<MemorySpace> kernel{
        particles,        grid,      elastic_material<real_t>(ElasticModel::FixedCorotated, 1, 0),
        ExternalForces{}, real_t(0), apic,
        outside,          {},        NodeBox::whole(grid)};
    Kokkos::deep_copy(nodes, real_t(0));
    switch (strategy) {
      case P2GStrategy::Atomic: p2g_atomic(space, kernel, nodes); break;
      case P2GStrategy::Scatter: p2g_scatter(space, kernel, GridCopies<ExecutionSpace>(grid.num_nodes()), nodes); break;
      case P2GStrategy::Tiled: p2g_tiled(space, kernel, nodes, tiling); break;
    }
    space.fence();
  }
  void update() {
    Kokkos::View<double, MemorySpace> work("work");
    grid_update(ExecutionSpace(), nodes, grid, NodeBox::whole(grid), Vec3<real_t>::zero(), GridBoundary{}, real_t(0),
                work);
  }
  // G2P, which must find no particle in a bad state (a finite, non-inverted input stays so at dt = 0).
  void g2p(bool apic) {
    G2PSummaryView<MemorySpace> summary("summary");
    mpmrom::g2p(ExecutionSpace(), particles, nodes, grid, real_t(0), apic, problems, summary);
    auto counts = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), problems);
    EXPECT_EQ(counts(problem_not_finite), 0);
    EXPECT_EQ(counts(problem_inverted), 0);
  }
};

template <class ExecutionSpace>
Totals particle_state(const TransferSetup<ExecutionSpace>& s, bool apic) {
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.particles.x);
  auto v = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.particles.v);
  auto C = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.particles.C);
  auto m = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.particles.mass);
  return particle_totals(x, v, C, m, s.grid.dx, apic);
}

template <class ExecutionSpace>
Totals grid_state(const TransferSetup<ExecutionSpace>& s, bool velocity) {
  auto nodes = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.nodes);
  return grid_totals(nodes, s.grid, velocity);
}

// Tiles shared by 64 particles: the particles' stencils start at nodes 3..11 of each axis, so any team's box fits in
// 11^3 = 1331 nodes (42.6 kB in double: inside a GPU block's default 48 kB of shared memory).
template <class ExecutionSpace>
P2GTiling shared_tiles() {
  return {default_p2g_tiling<ExecutionSpace>().team_size, 64, 1331};
}

template <class ExecutionSpace>
void check_conservation(P2GStrategy strategy, bool apic) {
  const double A[3][3] = {{0.1, -0.7, 0.2}, {0.7, 0.0, -0.3}, {-0.2, 0.3, -0.1}}, b[3] = {0.3, -0.2, 0.5};
  const int n = 3000;
  TransferSetup<ExecutionSpace> s(n, A, b, 0.5, 3);
  const Totals particles_before = particle_state(s, apic);
  s.p2g(strategy, apic, shared_tiles<ExecutionSpace>());
  const Totals grid_momenta = grid_state(s, false);
  s.update();
  const Totals grid_velocities = grid_state(s, true);
  s.g2p(apic);
  const Totals particles_after = particle_state(s, apic);
  // Totals are sums of 27 n rounded terms whose magnitudes add up to at most 8 x the total mass (|x| < 0.5,
  // |v| < 3): rounding errors of random sign grow like sqrt(27 n) eps times that. PIC loses the affine part, so
  // angular momentum is checked with APIC only.
  const double tol = std::sqrt(27.0 * n) * eps * 8 * particles_before.mass;
  expect_totals_near(grid_momenta, particles_before, tol, tol, tol, apic, "P2G");
  expect_totals_near(grid_velocities, grid_momenta, tol, tol, tol, true, "grid update");
  expect_totals_near(particles_after, grid_velocities, tol, tol, tol, apic, "G2P");
  EXPECT_GT(particles_before.mass, 0.5 * n);
}

template <class ExecutionSpace>
void check_affine_reproduced(P2GStrategy strategy) {
  const double A[3][3] = {{0.1, -0.7, 0.2}, {0.7, 0.05, -0.3}, {-0.2, 0.3, -0.1}}, b[3] = {0.3, -0.2, 0.5};
  const int n = 2000;
  TransferSetup<ExecutionSpace> s(n, A, b, 0.0, 5);
  s.p2g(strategy, true, shared_tiles<ExecutionSpace>());
  s.update();
  s.g2p(true);
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.particles.x);
  auto v = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.particles.v);
  auto C = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.particles.C);
  // Exact in exact arithmetic (partition of unity and linear completeness); rounding of a 27-term weighted sum of
  // O(1) values, divided by node masses, stays below ~100 eps. C carries a 4/dx^2 = 256 factor on offsets of size dx,
  // which amplifies rounding by ~1/dx = 8.
  for (int p = 0; p < n; ++p)
    for (int d = 0; d < 3; ++d) {
      const double exact = b[d] + A[d][0] * x(p, 0) + A[d][1] * x(p, 1) + A[d][2] * x(p, 2);
      EXPECT_NEAR(v(p, d), exact, 100 * eps) << "point " << p;
      for (int e = 0; e < 3; ++e) EXPECT_NEAR(C(p, d, e), A[d][e], 1000 * eps) << "point " << p;
    }
}

// Tiled P2G gives the atomic grid, to summation-order rounding, whether every team keeps a tile (one particle a
// team: a 27-node box), many particles share one tile, or every team's box is too large and falls back to atomics.
template <class ExecutionSpace>
void check_tiles_match_atomics() {
  const double A[3][3] = {{0.1, -0.7, 0.2}, {0.7, 0.0, -0.3}, {-0.2, 0.3, -0.1}}, b[3] = {0.3, -0.2, 0.5};
  TransferSetup<ExecutionSpace> s(3000, A, b, 0.5, 7);
  s.p2g(P2GStrategy::Atomic, true);
  auto reference = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.nodes);
  const int team_size = default_p2g_tiling<ExecutionSpace>().team_size;
  const P2GTiling every_team_tiles{team_size, 1, 27}, every_team_falls_back{team_size, 64, 27};
  for (const P2GTiling tiling : {every_team_tiles, shared_tiles<ExecutionSpace>(), every_team_falls_back}) {
    s.p2g(P2GStrategy::Tiled, true, tiling);
    auto tiled = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.nodes);
    // A node sums about 220 terms (8 particles a cell, 27 cells): two summation orders differ by at most
    // 2 x 220 eps x the terms' absolute sum, which is within ~2x of the largest node value.
    double scale = 0, worst = 0;
    for (int node = 0; node < s.grid.num_nodes(); ++node)
      for (int c = 0; c < 4; ++c) {
        scale = std::max(scale, std::fabs(double(reference(node, c))));
        worst = std::max(worst, std::fabs(double(tiled(node, c)) - double(reference(node, c))));
      }
    EXPECT_GT(scale, 1.0);
    EXPECT_LE(worst, 1e3 * eps * scale) << tiling.particles_per_team << " particles a team, tiles of at most "
                                        << tiling.max_tile_nodes << " nodes";
  }
}

// G2P in blocks of particles (CPUs) gives one thread a particle's state: the same terms in the same order for each
// particle, so the two differ only where the compiler contracts a multiply-add differently in the vectorised lanes,
// one rounding a term of the 27-term sums at most (27 eps of their absolute sums, within a few times each field's
// largest entry); 64 eps of that allows it. The last block holds one particle and one particle sits outside the grid.
template <class ExecutionSpace>
void check_g2p_launches_agree() {
  const double A[3][3] = {{0.1, -0.7, 0.2}, {0.7, 0.0, -0.3}, {-0.2, 0.3, -0.1}}, b[3] = {0.3, -0.2, 0.5};
  const int n = 3001, outside = 5;
  const real_t dt = real_t(0.01);
  using Particles = ParticleViews<typename ExecutionSpace::memory_space>;
  const auto run = [&](ParticleLaunch launch, real_t& speed) {
    TransferSetup<ExecutionSpace> s(n, A, b, 0.5, 11);
    Kokkos::deep_copy(Kokkos::subview(s.particles.x, outside, Kokkos::ALL), real_t(0.99));  // stencil past the grid
    s.p2g(P2GStrategy::Atomic, true);
    s.update();
    G2PSummaryView<typename ExecutionSpace::memory_space> summary("summary");
    g2p(ExecutionSpace(), s.particles, s.nodes, s.grid, dt, true, s.problems, summary, launch);
    G2PSummary result;
    Kokkos::deep_copy(result, summary);
    speed = result.max_speed;
    return s.particles;
  };
  real_t speed_per_particle = 0, speed_blocks = 0;
  const Particles one = run(ParticleLaunch::PerParticle, speed_per_particle);
  const Particles blocks = run(ParticleLaunch::Blocks, speed_blocks);
  const auto expect_near = [&](const auto& a_view, const auto& b_view, const char* field) {
    auto a = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), a_view);
    auto c = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), b_view);
    double scale = 0, worst = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      scale = std::max(scale, std::fabs(double(a.data()[i])));
      worst = std::max(worst, std::fabs(double(a.data()[i]) - double(c.data()[i])));
    }
    EXPECT_GT(scale, 0.0) << field;
    EXPECT_LE(worst, 64 * eps * scale) << field;
  };
  expect_near(one.x, blocks.x, "x");
  expect_near(one.v, blocks.v, "v");
  expect_near(one.C, blocks.C, "C");
  expect_near(one.F, blocks.F, "F");
  EXPECT_NEAR(speed_blocks, speed_per_particle, 64 * eps * speed_per_particle);
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), blocks.x);
  for (int d = 0; d < 3; ++d) EXPECT_EQ(x(outside, d), real_t(0.99)) << "the particle outside the grid moved";
}

// P2G in blocks of particles (CPUs) gives one thread a particle's grid and energies, with stress (F away from I,
// dt > 0), for the atomic and the scatter-view strategies. Each node's terms are the same; their summation order
// may differ (atomics, and the threads' shares of the particles), as in check_tiles_match_atomics, whose bound this
// takes. The last block holds one particle and one particle sits outside the grid.
template <class ExecutionSpace>
void check_p2g_launches_agree(P2GStrategy strategy) {
  using MemorySpace = typename ExecutionSpace::memory_space;
  const double A[3][3] = {{0.1, -0.7, 0.2}, {0.7, 0.0, -0.3}, {-0.2, 0.3, -0.1}}, b[3] = {0.3, -0.2, 0.5};
  const int n = 3001, outside = 5;
  TransferSetup<ExecutionSpace> s(n, A, b, 0.5, 13);
  auto F = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.particles.F);
  std::mt19937_64 rng(14);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  for (int p = 0; p < n; ++p)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) F(p, i, j) += real_t(u(rng));
  Kokkos::deep_copy(s.particles.F, F);
  Kokkos::deep_copy(Kokkos::subview(s.particles.x, outside, Kokkos::ALL), real_t(0.99));  // stencil past the grid
  const auto run = [&](ParticleLaunch launch, Kokkos::View<double*, MemorySpace> energy) {
    Kokkos::deep_copy(s.outside, 0);
    const P2GParticle<MemorySpace> kernel{
        s.particles,      s.grid,       elastic_material<real_t>(ElasticModel::FixedCorotated, 1e3, 0.3),
        ExternalForces{}, real_t(0.01), true,
        s.outside,        energy,       NodeBox::whole(s.grid)};
    Kokkos::deep_copy(s.nodes, real_t(0));
    if (strategy == P2GStrategy::Atomic) {
      p2g_atomic(ExecutionSpace(), kernel, s.nodes, launch);
    } else {
      p2g_scatter(ExecutionSpace(), kernel, GridCopies<ExecutionSpace>(s.grid.num_nodes()), s.nodes, launch);
    }
    int outside_count = 0;
    Kokkos::deep_copy(outside_count, s.outside);
    EXPECT_EQ(outside_count, 1);
    return Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.nodes);
  };
  Kokkos::View<double*, MemorySpace> energy_one("energy_one", n), energy_blocks("energy_blocks", n);
  const auto one = run(ParticleLaunch::PerParticle, energy_one);
  const auto blocks = run(ParticleLaunch::Blocks, energy_blocks);
  double scale = 0, worst = 0;
  for (int node = 0; node < s.grid.num_nodes(); ++node)
    for (int c = 0; c < 4; ++c) {
      scale = std::max(scale, std::fabs(double(one(node, c))));
      worst = std::max(worst, std::fabs(double(blocks(node, c)) - double(one(node, c))));
    }
  EXPECT_GT(scale, 1.0);
  EXPECT_LE(worst, 1e3 * eps * scale);
  auto e1 = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), energy_one);
  auto e2 = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), energy_blocks);
  // The same SVD of the same F, inlined into two kernels whose multiply-adds the compiler may contract differently:
  // a few roundings of the energy's O(1) terms.
  for (int p = 0; p < n; ++p) EXPECT_NEAR(e1(p), e2(p), 64 * eps * std::fabs(e1(p))) << "particle " << p;
  EXPECT_EQ(e2(outside), 0.0);
}

// G2P's summary holds the box of the nodes the particles' new stencils reach, which the FOM's next step prepares:
// against the stencils recomputed here from the positions it stored. A coordinate on a cell's boundary may floor to
// either side in differently compiled code, hence one node of tolerance on each bound (the FOM pads the box by one).
// dt moves the points about a cell, so the box is not the one they started from.
template <class ExecutionSpace>
void check_g2p_box(ParticleLaunch launch) {
  using MemorySpace = typename ExecutionSpace::memory_space;
  const double A[3][3] = {{0.1, -0.7, 0.2}, {0.7, 0.0, -0.3}, {-0.2, 0.3, -0.1}}, b[3] = {0.3, -0.2, 0.5};
  TransferSetup<ExecutionSpace> s(3001, A, b, 0.5, 17);
  s.p2g(P2GStrategy::Atomic, true);
  s.update();
  G2PSummaryView<MemorySpace> summary("summary");
  g2p(ExecutionSpace(), s.particles, s.nodes, s.grid, real_t(0.25), true, s.problems, summary, launch);
  G2PSummary result;
  Kokkos::deep_copy(result, summary);
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.particles.x);
  NodeBox expected = NodeBox::none();
  for (std::size_t p = 0; p < x.extent(0); ++p)
    expected.include_stencil(quadratic_stencil(load_vec3(x, int(p)), s.grid.origin, s.grid.inv_dx).base);
  for (int d = 0; d < 3; ++d) {
    EXPECT_GT(expected.lo[d], 0);  // a box inside the grid: the test would not see a box that is the whole grid
    EXPECT_LT(expected.hi[d], s.grid.dims[d] - 1);
    EXPECT_NEAR(result.box.lo[d], expected.lo[d], 1) << "axis " << d;
    EXPECT_NEAR(result.box.hi[d], expected.hi[d], 1) << "axis " << d;
  }
}

// Scatter P2G prepared over a box that holds every stencil gives the nodes of the box the whole grid's sums (on host
// backends bit for bit: the same adds in the same order; atomics on devices within check_tiles_match_atomics' bound),
// leaves the nodes outside it untouched, and leaves its copies zero there: a second P2G with the same copies gives
// the same sums.
template <class ExecutionSpace>
void check_scatter_over_a_box() {
  using MemorySpace = typename ExecutionSpace::memory_space;
  constexpr bool host = Kokkos::SpaceAccessibility<ExecutionSpace, Kokkos::HostSpace>::accessible;
  const double A[3][3] = {{0.1, -0.7, 0.2}, {0.7, 0.0, -0.3}, {-0.2, 0.3, -0.1}}, b[3] = {0.3, -0.2, 0.5};
  TransferSetup<ExecutionSpace> s(3000, A, b, 0.5, 19);
  const auto kernel_over = [&](const NodeBox& reach) {
    return P2GParticle<MemorySpace>{
        s.particles,      s.grid,       elastic_material<real_t>(ElasticModel::FixedCorotated, 1e3, 0.3),
        ExternalForces{}, real_t(0.01), true,
        s.outside,        {},           reach};
  };
  const GridCopies<ExecutionSpace> copies(s.grid.num_nodes());
  Kokkos::deep_copy(s.nodes, real_t(0));
  p2g_scatter(ExecutionSpace(), kernel_over(NodeBox::whole(s.grid)), copies, s.nodes);
  const auto whole = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.nodes);
  auto x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.particles.x);
  NodeBox box = NodeBox::none();
  for (std::size_t p = 0; p < x.extent(0); ++p)
    box.include_stencil(quadratic_stencil(load_vec3(x, int(p)), s.grid.origin, s.grid.inv_dx).base);
  box = padded(box, 1, s.grid);
  ASSERT_LT(box.num_nodes(), s.grid.num_nodes() / 2);
  const real_t untouched = 7;
  for (int round = 0; round < 2; ++round) {
    Kokkos::deep_copy(s.nodes, untouched);
    zero_box(ExecutionSpace(), s.nodes, box, s.grid);
    p2g_scatter(ExecutionSpace(), kernel_over(box), copies, s.nodes);
    const auto nodes = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), s.nodes);
    double scale = 0;
    for (int node = 0; node < s.grid.num_nodes(); ++node)
      for (int c = 0; c < 4; ++c) scale = std::max(scale, std::fabs(double(whole(node, c))));
    for (int i = 0; i < s.grid.dims[0]; ++i)
      for (int j = 0; j < s.grid.dims[1]; ++j)
        for (int k = 0; k < s.grid.dims[2]; ++k) {
          const int node = s.grid.index(i, j, k), ijk[3] = {i, j, k};
          bool inside = true;
          for (int d = 0; d < 3; ++d) inside = inside && ijk[d] >= box.lo[d] && ijk[d] <= box.hi[d];
          for (int c = 0; c < 4; ++c) {
            if (!inside)
              ASSERT_EQ(nodes(node, c), untouched) << "node " << node << " outside the box, round " << round;
            else if (host)
              ASSERT_EQ(nodes(node, c), whole(node, c)) << "node " << node << ", round " << round;
            else
              ASSERT_NEAR(nodes(node, c), whole(node, c), 1e3 * eps * scale) << "node " << node;
          }
        }
  }
}

template <class ExecutionSpace>
class Transfers : public ::testing::Test {};
TYPED_TEST_SUITE(Transfers, EnabledBackends, BackendName);

TYPED_TEST(Transfers, ApicConservesMassMomentumAngularMomentumAtomic) {
  check_conservation<TypeParam>(P2GStrategy::Atomic, true);
}
TYPED_TEST(Transfers, ApicConservesMassMomentumAngularMomentumScatter) {
  check_conservation<TypeParam>(P2GStrategy::Scatter, true);
}
TYPED_TEST(Transfers, PicConservesMassAndMomentum) { check_conservation<TypeParam>(P2GStrategy::Atomic, false); }
TYPED_TEST(Transfers, ApicReproducesAffineFieldAtomic) { check_affine_reproduced<TypeParam>(P2GStrategy::Atomic); }
TYPED_TEST(Transfers, ApicReproducesAffineFieldScatter) { check_affine_reproduced<TypeParam>(P2GStrategy::Scatter); }
TYPED_TEST(Transfers, ApicConservesMassMomentumAngularMomentumTiled) {
  check_conservation<TypeParam>(P2GStrategy::Tiled, true);
}
TYPED_TEST(Transfers, ApicReproducesAffineFieldTiled) { check_affine_reproduced<TypeParam>(P2GStrategy::Tiled); }
TYPED_TEST(Transfers, TiledMatchesAtomicsWithEveryTileShape) { check_tiles_match_atomics<TypeParam>(); }
TYPED_TEST(Transfers, G2PBlocksMatchOneThreadAParticle) { check_g2p_launches_agree<TypeParam>(); }
TYPED_TEST(Transfers, P2GBlocksMatchOneThreadAParticleAtomic) {
  check_p2g_launches_agree<TypeParam>(P2GStrategy::Atomic);
}
TYPED_TEST(Transfers, G2PSummaryHoldsTheNewStencilsBoxOneThreadAParticle) {
  check_g2p_box<TypeParam>(ParticleLaunch::PerParticle);
}
TYPED_TEST(Transfers, G2PSummaryHoldsTheNewStencilsBoxBlocks) { check_g2p_box<TypeParam>(ParticleLaunch::Blocks); }
TYPED_TEST(Transfers, ScatterOverABoxGivesTheWholeGridsSums) { check_scatter_over_a_box<TypeParam>(); }
TYPED_TEST(Transfers, P2GBlocksMatchOneThreadAParticleScatter) {
  check_p2g_launches_agree<TypeParam>(P2GStrategy::Scatter);
}

}  // namespace
}  // namespace mpmrom::test
