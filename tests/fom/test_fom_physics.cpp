// Whole-solver validation against known answers: free fall, rigid rotation, axial vibration of a bar, and two
// colliding spheres. These run the FomSolver on the build's default execution space.
#include <cmath>
#include <limits>
#include <vector>

#include "backends.hpp"
#include "fom/fom.hpp"
#include "fixtures.hpp"
#include "scene/sampling.hpp"

namespace mpmrom::test {
namespace {

// Mass-weighted mean of one component of the positions (or velocities) of points [first, last).
double mass_weighted_mean(const FomSolver& solver, bool velocity, int axis, std::size_t first, std::size_t last) {
  const ParticleFrame f = solver.frame();
  std::vector<real_t> X, mass, volume;
  solver.reference(X, mass, volume);
  const std::vector<real_t>& field = velocity ? f.v : f.x;
  double m = 0, sum = 0;
  for (std::size_t p = first; p < last; ++p) {
    m += mass[p];
    sum += mass[p] * field[3 * p + axis];
  }
  return sum / m;
}

double center_of_mass(const FomSolver& solver, int axis, std::size_t first, std::size_t last) {
  return mass_weighted_mean(solver, false, axis, first, last);
}

double mean_velocity(const FomSolver& solver, int axis, std::size_t first, std::size_t last) {
  return mass_weighted_mean(solver, true, axis, first, last);
}

struct Energies {
  double kinetic = 0, elastic = 0;
  double total() const { return kinetic + elastic; }
};

Energies energies(const FomSolver& solver, const Scene& scene) {
  const ParticleFrame f = solver.frame();
  std::vector<real_t> X, mass, volume;
  solver.reference(X, mass, volume);
  const auto material = elastic_material<double>(
      scene.material.model == ElasticModelKind::NeoHookean ? ElasticModel::NeoHookean : ElasticModel::FixedCorotated,
      scene.material.youngs_modulus, scene.material.poisson_ratio);
  Energies e;
  for (std::size_t p = 0; p < mass.size(); ++p) {
    Mat3<double> F;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) F(i, j) = f.F[9 * p + 3 * i + j];
    double v2 = 0;
    for (int d = 0; d < 3; ++d) v2 += double(f.v[3 * p + d]) * f.v[3 * p + d];
    e.kinetic += 0.5 * mass[p] * v2;
    e.elastic += volume[p] * energy_density(material, F);
  }
  return e;
}

TEST(FomPhysics, FreeFallFollowsTheParabola) {
  const Scene scene = fixture_scene("free_fall.toml");
  FomSolver solver(scene);
  const double g = 9.81, z0 = center_of_mass(solver, 2, 0, solver.num_particles());
  const double dt = 1e-3;
  const int steps = 300;
  for (int n = 0; n < steps; ++n) solver.step(dt);
  const double t = steps * dt, z = center_of_mass(solver, 2, 0, solver.num_particles());
  // Symplectic Euler on a uniform field gives exactly z0 - g dt^2 n (n + 1) / 2: the grid adds g dt to every
  // velocity and partition of unity hands it back unchanged. Rounding: n steps of O(1) values, ~n eps.
  EXPECT_NEAR(z, z0 - g * dt * dt * steps * (steps + 1) / 2, 4 * steps * eps * (1 + z0));
  // Against the continuous parabola the difference is the scheme's g t dt / 2.
  EXPECT_NEAR(z, z0 - g * t * t / 2, g * t * dt / 2 * 1.001 + 4 * steps * eps);
  // A uniform velocity field has zero gradient, so F stays the identity (to rounding of sum grad w = 0).
  const ParticleFrame f = solver.frame();
  for (std::size_t p = 0; p < solver.num_particles(); ++p)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) ASSERT_NEAR(f.F[9 * p + 3 * i + j], i == j ? 1.0 : 0.0, 64 * steps * eps);
}

// Free fall: the budget is the work of gravity counted at the updated velocities, sum m g dt . v_{n+1}, which exceeds
// the kinetic energy gained, m g dt . (v_n + v_{n+1}) / 2, by m g^2 dt^2 / 2 per step: over a time T in N steps of
// at most dt_max, 0 <= budget - energy <= M g^2 dt_max T / 2 (and the uniform field has no elastic energy).
TEST(FomPhysics, FreeFallEnergyEqualsTheWorkOfGravityToOneStep) {
  const Scene scene = override_scene(fixture_scene("free_fall.toml"), {"time.dt=0.002"});
  FomSolver solver(scene);
  solver.advance_to(scene.end_time);
  std::vector<real_t> X, mass, volume;
  solver.reference(X, mass, volume);
  double M = 0;
  for (const real_t m : mass) M += m;
  const double g = 9.81, T = scene.end_time, energy = solver.energy().total(), budget = solver.energy_budget();
  const double rounding = 100 * std::numeric_limits<real_t>::epsilon() * budget;
  EXPECT_GE(budget - energy, -rounding);
  EXPECT_LE(budget - energy, 0.5 * M * g * g * scene.time_step * T + rounding);
  EXPECT_NEAR(energy, 0.5 * M * (g * T) * (g * T), 0.5 * M * g * g * scene.time_step * T + rounding);
}

// The periodic energy check rides on the next step's P2G (each point's V Psi(F) from the SVD its stress needs): it
// sees the energy a separate pass over the same state sees. Both sum in double the same formulas of the same F, but
// compiled into different kernels they may round differently: by a few eps of the terms each density is made of,
// which for neo-Hookean are O(mu) (mu (F:F - 3) / 2 - mu ln J cancel down to O(mu strain^2)). Hence 16 eps of the
// total energy plus 3 mu times the volume.
TEST(FomPhysics, EnergyCheckedInP2GEqualsASeparatePass) {
  for (const std::string model : {"fixed_corotated", "neo_hookean"}) {
    std::string text = pushed_block_scene("pushed_block", 0.5, 5, 0.4, {1.0}, 0);
    text.replace(text.find("[material]\n"), 11, "[material]\nmodel = \"" + model + "\"\n");
    const Scene scene = parse_scene(text, "pushed_block");
    FomSolver solver(scene);
    const double dt = solver.stable_time_step();
    for (int s = 0; s < 16; ++s) solver.step(dt);
    EXPECT_EQ(solver.last_energy_check().step, -1) << "the check of step 16's state is due in step 17";
    const ParticleEnergy separate = solver.energy();
    ASSERT_GT(separate.elastic, 1e-3 * separate.total()) << model << ": the block should be strained";
    solver.step(dt);
    ASSERT_EQ(solver.last_energy_check().step, 16) << model;
    std::vector<real_t> X, mass, volume;
    solver.reference(X, mass, volume);
    double total_volume = 0;
    for (const real_t v : volume) total_volume += v;
    const double mu = scene.material.youngs_modulus / (2 * (1 + scene.material.poisson_ratio));
    EXPECT_NEAR(solver.last_energy_check().energy, separate.total(),
                16 * std::numeric_limits<real_t>::epsilon() * (separate.total() + 3 * mu * total_volume))
        << model;
  }
}

TEST(FomPhysics, RigidRotationKeepsFOrthogonalAndStressFree) {
  const Scene scene = fixture_scene("spinning_sphere.toml");
  FomSolver solver(scene);
  const double omega = 2.0;
  const Energies start = energies(solver, scene);
  const double dt = solver.stable_time_step();
  solver.advance_to(scene.end_time);
  const double t = solver.time();
  const ParticleFrame f = solver.frame();
  double worst = 0;
  for (std::size_t p = 0; p < solver.num_particles(); ++p) {
    Mat3<double> F;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) F(i, j) = f.F[9 * p + 3 * i + j];
    worst = std::max(worst, frobenius_norm(transpose(F) * F - Mat3<double>::identity()));
  }
  // The forward update F <- (I + dt W) F with W skew stretches by dt^2 W^T W per step: |F^T F - I| grows like
  // sqrt(2) t dt omega^2. Centrifugal strain rho omega^2 R^2 / E = 1.6e-7 is negligible at E = 1e7.
  const double bound = 2 * std::sqrt(2.0) * t * dt * omega * omega + 1e3 * eps;
  EXPECT_LT(worst, bound) << "F drifted from a rotation";
  const Energies end = energies(solver, scene);
  // Stress free: the elastic energy stays a negligible part of the kinetic energy of the spin.
  EXPECT_LT(end.elastic, 1e-3 * start.kinetic);
  EXPECT_NEAR(end.kinetic, start.kinetic, 0.01 * start.kinetic);
}

// A free-free bar along x with nu = 0, so that its axial waves travel at c = sqrt(E / rho) exactly as in 1D.
// Set in its first mode, v = V cos(pi (x - x0) / L), it vibrates with period T = 2 L / c.

// Runs the bar for 1.25 periods and returns (measured period, largest relative energy change).
std::pair<double, double> vibrate_bar(double dx) {
  const Scene scene = fixture_scene("vibrating_bar.toml",
                                    {"body.0.spacing=" + std::to_string(dx / 2), "grid.dx=" + std::to_string(dx)});
  FomSolver solver(scene);
  const double L = 1.0, c = 100.0, V = 0.05;  // V / c = 5e-4: small strain, linear regime
  {
    auto v = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), solver.particles().v);
    auto X = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), solver.particles().X);
    for (std::size_t p = 0; p < solver.num_particles(); ++p)
      v(p, 0) = real_t(V * std::cos(M_PI * (X(p, 0) + L / 2) / L));
    Kokkos::deep_copy(solver.particles().v, v);
  }
  const std::size_t n = solver.num_particles();
  // Points in the left quarter: their mean velocity is V cos(2 pi t / T) times a positive constant.
  std::vector<real_t> X, mass, volume;
  solver.reference(X, mass, volume);
  std::vector<std::size_t> left;
  for (std::size_t p = 0; p < n; ++p)
    if (X[3 * p] < -L / 4) left.push_back(p);
  auto left_velocity = [&] {
    const ParticleFrame f = solver.frame();
    double m = 0, mv = 0;
    for (std::size_t p : left) {
      m += mass[p];
      mv += mass[p] * f.v[3 * p];
    }
    return mv / m;
  };
  const Energies e0 = energies(solver, scene);
  const double T = 2 * L / c;
  std::vector<double> crossings;
  double previous = left_velocity(), previous_t = 0, drift = 0;
  const double dt = 0.25 * dx / c;
  while (solver.time() < 1.3 * T) {
    solver.step(dt);
    const double now = left_velocity();
    if ((previous > 0) != (now > 0))  // linear interpolation of the zero crossing
      crossings.push_back(previous_t + dt * previous / (previous - now));
    previous = now;
    previous_t = solver.time();
    drift = std::max(drift, std::fabs(energies(solver, scene).total() - e0.total()) / e0.total());
  }
  EXPECT_GE(crossings.size(), 2u);
  const double period = crossings.size() >= 2 ? 2 * (crossings[1] - crossings[0]) : 0;
  return {period, drift};
}

TEST(FomPhysics, AxialVibrationOfABarHasTheAnalyticPeriod) {
  const double T = 2 * 1.0 / 100.0;
  // Quadratic B-spline MPM is second-order accurate for this smooth mode: the period error behaves like
  // C (dx / L)^2 with C of order one (the dispersion (k dx)^2 / 12 alone gives C = pi^2 / 12). We allow C = 2 at
  // dx = L / 20 and require the second-order rate: halving dx must cut the error by more than 3 (ideal 4).
  const auto coarse = vibrate_bar(0.1);
  const auto fine = vibrate_bar(0.05);
  const double coarse_error = std::fabs(coarse.first - T) / T, fine_error = std::fabs(fine.first - T) / T;
  std::printf("bar period: dx = 0.1 -> %.6f s (error %.2f%%), dx = 0.05 -> %.6f s (error %.2f%%), analytic %.6f s\n",
              coarse.first, 100 * coarse_error, fine.first, 100 * fine_error, T);
  std::printf("bar energy drift over 1.3 periods: %.3f%% (dx = 0.1), %.3f%% (dx = 0.05)\n", 100 * coarse.second,
              100 * fine.second);
  EXPECT_LT(fine_error, 2 * 0.05 * 0.05);
  EXPECT_GT(coarse_error / fine_error, 3.0);
  // APIC dissipates a little energy each step (the grid velocity is a projection); it must fall with dx too.
  EXPECT_LT(fine.second, 0.05);
  EXPECT_LT(fine.second, coarse.second);
}

// Two identical elastic spheres approach each other along x (Sulsky, Chen and Schreyer 1994, in 3D): mirror images
// about x = 0, so the motion must stay symmetric; no walls are reached, so momentum is conserved; they must bounce.

TEST(FomPhysics, CollidingSpheresReboundSymmetrically) {
  const Scene scene = fixture_scene("colliding_spheres.toml");
  FomSolver solver(scene);
  const std::size_t n = solver.num_particles(), half = n / 2;
  ASSERT_EQ(sample_scene(scene).body[half], 1);  // bodies are sampled one after the other, equal in size
  const Energies e0 = energies(solver, scene);
  double worst_gain = 0, worst_asymmetry = 0, worst_momentum = 0, least_total = e0.total();
  const double v0 = 0.5, total_mass = 2 * scene.material.density * 4.0 / 3.0 * M_PI * 0.001;
  for (int frame = 1; frame <= 60; ++frame) {
    solver.advance_to(0.01 * frame);
    const Energies e = energies(solver, scene);
    worst_gain = std::max(worst_gain, (e.total() - e0.total()) / e0.total());
    least_total = std::min(least_total, e.total());
    worst_asymmetry =
        std::max(worst_asymmetry, std::fabs(center_of_mass(solver, 0, 0, half) + center_of_mass(solver, 0, half, n)));
    worst_momentum = std::max(worst_momentum, std::fabs(mean_velocity(solver, 0, 0, n)) * total_mass);
  }
  const double v_left = mean_velocity(solver, 0, 0, half), v_right = mean_velocity(solver, 0, half, n);
  const Energies e_end = energies(solver, scene);
  std::printf("spheres: velocity after %.4f / %.4f m/s (before +-%.2f), energy kept %.1f%% (lowest %.1f%%)\n", v_left,
              v_right, v0, 100 * e_end.total() / e0.total(), 100 * least_total / e0.total());
  // Momentum: sums of ~2000 rounded terms, each step; 1e3 eps per unit of momentum m v0 bounds the drift.
  EXPECT_LT(worst_momentum, 1e3 * eps * total_mass * v0 + 1e-12);
  // Symmetry: mirror-image bodies on a mirror-symmetric grid; only the order of atomic adds differs.
  EXPECT_LT(worst_asymmetry, 1e4 * eps * 0.2);
  // They bounce apart with a coefficient of restitution close to one (elastic bodies; measured 0.91 here).
  EXPECT_LT(v_left, -0.8 * v0);
  EXPECT_GT(v_right, 0.8 * v0);
  // Energy bookkeeping: explicit APIC never creates energy (beyond an O(dt) time-discretisation error), and the grid
  // projection dissipates a part that shrinks with dx (53 % kept at dx = 0.05, 83 % at dx = 0.025): at this
  // resolution at least three quarters must survive the impact.
  EXPECT_LT(worst_gain, 0.01);
  EXPECT_GT(least_total / e0.total(), 0.75);
}

// Each step's grid passes cover only the nodes the particles reach (the box the last step's G2P found, one node of
// margin), and the other nodes stay zero: a point whose stencil fell outside that box would drop its mass, and a
// node left over from an earlier box would stay non-zero. The free-fall box, from rest over 0.3 s (9 cells of 5 cm,
// a node at a time) and thrown down at 200 m/s (4 cells a step, beyond the margins), for each P2G strategy: after
// every step the grid must hold the whole mass, and every node outside the box of the step's own stencils must be
// zero (two nodes of slack: G2P's margin, and a coordinate that floors either way in differently compiled code).
// Each point's 27 weights sum to one up to a few roundings, so the grid's total differs from the particles' by
// rounding of O(points) terms: 16 eps per point.
TEST(FomGrid, EveryStepsGridHoldsTheBodysWholeMassAndNothingElse) {
  const Scene scene = fixture_scene("free_fall.toml");
  for (const P2GStrategy strategy : {P2GStrategy::Atomic, P2GStrategy::Scatter, P2GStrategy::Tiled})
    for (const double speed : {0.0, 200.0}) {
      FomSolver solver(scene, strategy);
      auto v = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), solver.particles().v);
      for (std::size_t p = 0; p < v.extent(0); ++p) v(p, 2) = real_t(-speed);
      Kokkos::deep_copy(solver.particles().v, v);
      const GridGeometry<real_t> grid = solver.grid();
      std::vector<real_t> X, mass, volume;
      solver.reference(X, mass, volume);
      double total = 0;
      for (const real_t m : mass) total += m;
      for (int n = 0; n < (speed > 0 ? 8 : 300); ++n) {
        const ParticleFrame start = solver.frame();
        NodeBox box = NodeBox::none();
        for (std::size_t p = 0; p < mass.size(); ++p) {
          const Vec3<real_t> x{{start.x[3 * p], start.x[3 * p + 1], start.x[3 * p + 2]}};
          box.include_stencil(quadratic_stencil(x, grid.origin, grid.inv_dx).base);
        }
        box = padded(box, 2, grid);
        solver.step(1e-3);
        const auto nodes = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), solver.grid_nodes());
        double grid_mass = 0;
        for (int i = 0; i < grid.dims[0]; ++i)
          for (int j = 0; j < grid.dims[1]; ++j)
            for (int k = 0; k < grid.dims[2]; ++k) {
              const int node = grid.index(i, j, k);
              grid_mass += nodes(node, 0);
              const bool inside = i >= box.lo[0] && i <= box.hi[0] && j >= box.lo[1] && j <= box.hi[1] &&
                                  k >= box.lo[2] && k <= box.hi[2];
              if (!inside)
                for (int c = 0; c < 4; ++c)
                  ASSERT_EQ(nodes(node, c), real_t(0)) << "node " << node << ", step " << n + 1 << ", " << speed;
            }
        ASSERT_NEAR(grid_mass, total, 16 * eps * mass.size() * total) << "step " << n + 1 << ", " << speed;
      }
    }
}

// Sizes derived from a scene's numbers are counted in doubles and refused before any int conversion: 1e10 cells
// along x alone would overflow it.
TEST(FomGrid, GridOfMoreNodesThanAnIntHoldsIsRefused) {
  const Scene scene = fixture_scene("box_under_force.toml", {"grid.hi=[1e9, 1.0, 1.0]"});
  try {
    (void)grid_for_scene(scene);
    ADD_FAILURE() << "a grid of 1e10 cells along x was accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_EQ(std::string(error.what()), "the grid would have more than 2e9 nodes; enlarge dx or shrink the domain");
  }
}

}  // namespace
}  // namespace mpmrom::test
