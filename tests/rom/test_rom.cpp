// The reduced-order model: the network's second-order kinematics against finite differences (the projection has
// its own test_projection.cpp), Newton inversion against maps with known inverses, a ROM on an exact (affine)
// manifold against the full-order model for both algorithms, and a batch of identical rollouts.
#include <cmath>
#include <random>
#include <vector>

#include "backends.hpp"
#include "fixtures.hpp"
#include "fom/fom.hpp"
#include "rom/detail/rom_stepper.hpp"
#include "manifold/nn/mlp_kinematics.hpp"
#include "rom/kernels/inversion.hpp"
#include "rom/kernels/manifold.hpp"
#include "rom/kernels/projection.hpp"
#include "scene/sampling.hpp"

namespace mpmrom::test {
namespace {

constexpr double eps = std::numeric_limits<real_t>::epsilon();

// ---------------------------------------------------------------------------------------------------------------
// Kinematics of the network: v, Fdot (second order) and dg/dxhat against central differences of
// SerialMlpForwardJacobian along xhatdot, in double whatever the build precision (the kernel is a template).
TEST(RomKinematics, MatchesFiniteDifferencesOfTheJacobian) {
  const int r = 5;
  const nn::MlpLayout layout = nn::MlpLayout::make(r, 16, 4);
  Kokkos::View<double*, Kokkos::HostSpace> params("params", layout.num_params);
  std::mt19937 gen(3);
  std::normal_distribution<double> normal(0, 0.5);
  for (int i = 0; i < layout.num_params; ++i) params(i) = normal(gen);
  nn::Mlp<double, Kokkos::HostSpace> mlp;
  mlp.layout = layout;
  mlp.params = params;
  for (int d = 0; d < 3; ++d) {
    mlp.standardization.input_mean[d] = 0.1 * d;
    mlp.standardization.input_scale[d] = 0.3 + 0.1 * d;
    mlp.standardization.output_scale[d] = 0.05 * (d + 1);
  }
  const double X[3] = {0.1, -0.2, 0.3};
  double xhat[r], rate[r];
  for (int q = 0; q < r; ++q) {
    xhat[q] = normal(gen);
    rate[q] = normal(gen);
  }
  nn::PointKinematics<double> kin;
  double J[3 * r];
  nn::SerialMlpKinematics<32>(mlp, X, xhat, rate, kin, J);
  // Central differences of step h along xhatdot: truncation ~ h^2 |g'''| ~ 1e-12, rounding ~ eps / h ~ 1e-10.
  const double h = 1e-6, tolerance = 1e-8;
  double plus[r], minus[r];
  for (int q = 0; q < r; ++q) {
    plus[q] = xhat[q] + h * rate[q];
    minus[q] = xhat[q] - h * rate[q];
  }
  double g0[3], gp[3], gm[3], F0[3][3], Fp[3][3], Fm[3][3], J0[3 * r], Jp[3 * r], Jm[3 * r];
  nn::SerialMlpForwardJacobian<32>(mlp, X, xhat, g0, F0, J0);
  nn::SerialMlpForwardJacobian<32>(mlp, X, plus, gp, Fp, Jp);
  nn::SerialMlpForwardJacobian<32>(mlp, X, minus, gm, Fm, Jm);
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(kin.g[i], g0[i], 1e-14);
    EXPECT_NEAR(kin.v[i], (gp[i] - gm[i]) / (2 * h), tolerance);
    for (int j = 0; j < 3; ++j) {
      EXPECT_NEAR(kin.F[i][j], F0[i][j], 1e-14);
      EXPECT_NEAR(kin.Fdot[i][j], (Fp[i][j] - Fm[i][j]) / (2 * h), tolerance);
    }
    for (int q = 0; q < r; ++q) EXPECT_NEAR(J[i * r + q], J0[i * r + q], 1e-14);
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Newton inversion against maps with known inverses.
struct WarpMap {  // g(X) = X + a sin(k X_{i+1}) e_i: invertible while a k < 1/2 (F diagonally dominant)
  real_t a, k;
  KOKKOS_INLINE_FUNCTION void position_and_gradient(const real_t X[3], const real_t*, real_t g[3],
                                                    real_t F[3][3]) const {
    for (int i = 0; i < 3; ++i) {
      const int j = (i + 1) % 3;
      g[i] = X[i] + a * std::sin(k * X[j]);
      for (int c = 0; c < 3; ++c)
        F[i][c] = (c == i ? real_t(1) : real_t(0)) + (c == j ? a * k * std::cos(k * X[j]) : 0);
    }
  }
};

struct FoldMap {  // g(X) = (X_0^2 + 1, X_1, X_2): no X maps to x_0 < 1, and F is singular at X_0 = 0
  KOKKOS_INLINE_FUNCTION void position_and_gradient(const real_t X[3], const real_t*, real_t g[3],
                                                    real_t F[3][3]) const {
    g[0] = X[0] * X[0] + 1;
    g[1] = X[1];
    g[2] = X[2];
    for (int i = 0; i < 3; ++i)
      for (int c = 0; c < 3; ++c) F[i][c] = i == c ? real_t(1) : real_t(0);
    F[0][0] = 2 * X[0];
  }
};

TEST(RomInversion, NewtonFindsTheReferencePositionOfKnownMaps) {
  const WarpMap warp{real_t(0.02), real_t(10)};  // a k = 0.2
  rom::NewtonSettings settings;
  settings.tolerance = real_t(1e-4 * 0.05);  // the ROM's default: 1e-4 cells of 5 cm
  std::mt19937 gen(5);
  std::uniform_real_distribution<double> uniform(-0.3, 0.3);
  for (int trial = 0; trial < 50; ++trial) {
    const real_t X_true[3] = {real_t(uniform(gen)), real_t(uniform(gen)), real_t(uniform(gen))};
    real_t g[3], F[3][3];
    warp.position_and_gradient(X_true, nullptr, g, F);
    const Vec3<real_t> x{{g[0], g[1], g[2]}};
    Vec3<real_t> X = x;  // start at the current position, as a cold start would
    ASSERT_TRUE(rom::SerialInvertMap(warp, x, nullptr, settings, X));
    // |g(X) - x| <= tol and |F^-1| <= 1 / (1 - a k) bound the error in X by 1.25 tol.
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(X[d], X_true[d], 1.25 * settings.tolerance + 16 * eps);
  }
  // No preimage: the iteration cannot reach the tolerance and reports failure instead of a wrong X.
  const FoldMap fold;
  Vec3<real_t> X{{real_t(0.5), 0, 0}};
  EXPECT_FALSE(rom::SerialInvertMap(fold, Vec3<real_t>{{real_t(0.5), 0, 0}}, nullptr, settings, X));
  // A singular F at the start is a failure too (det F <= 0).
  X = Vec3<real_t>{{0, 0, 0}};
  EXPECT_FALSE(rom::SerialInvertMap(fold, Vec3<real_t>{{real_t(2), 0, 0}}, nullptr, settings, X));
}

// ---------------------------------------------------------------------------------------------------------------
// Exact manifolds: affine maps g(X; xhat) = X + b + A (X - c), xhat = (b, A row-major), r = 12.
struct AffineManifold : rom::TeamFromSerial<AffineManifold> {
  real_t c[3];
  KOKKOS_INLINE_FUNCTION int latent_dim() const { return 12; }
  KOKKOS_INLINE_FUNCTION void position_and_gradient(const real_t X[3], const real_t* xhat, real_t g[3],
                                                    real_t F[3][3]) const {
    for (int i = 0; i < 3; ++i) {
      g[i] = X[i] + xhat[i];
      for (int j = 0; j < 3; ++j) {
        g[i] += xhat[3 + 3 * i + j] * (X[j] - c[j]);
        F[i][j] = (i == j ? real_t(1) : real_t(0)) + xhat[3 + 3 * i + j];
      }
    }
  }
  KOKKOS_INLINE_FUNCTION void kinematics(const real_t X[3], const real_t* xhat, const real_t* rate,
                                         nn::PointKinematics<real_t>& out, real_t* dgdxhat) const {
    position_and_gradient(X, xhat, out.g, out.F);
    for (int i = 0; i < 3; ++i) {
      out.v[i] = rate[i];
      for (int j = 0; j < 3; ++j) {
        out.v[i] += rate[3 + 3 * i + j] * (X[j] - c[j]);
        out.Fdot[i][j] = rate[3 + 3 * i + j];
      }
    }
    if (dgdxhat == nullptr) return;
    for (int i = 0; i < 3; ++i)
      for (int q = 0; q < 12; ++q) {
        real_t d = 0;
        if (q < 3)
          d = q == i ? real_t(1) : real_t(0);
        else if ((q - 3) / 3 == i)
          d = X[(q - 3) % 3] - c[(q - 3) % 3];
        dgdxhat[i * 12 + q] = d;
      }
  }
};

// A box translating and spinning with negligible stiffness (stress ~1e-6 Pa: its effect over the run, ~1e-9 m, is far
// below the tolerances); gravity and spin are set per test.
Scene affine_scene(const Vec3d& gravity, const Vec3d& spin) {
  Scene scene = fixture_scene("affine_motion.toml");
  scene.gravity = gravity;
  scene.bodies[0].angular_velocity = spin;
  return scene;
}

struct Motion {
  std::vector<double> X, mass, volume;
  std::vector<std::vector<double>> positions, velocities;  // per output frame
};

Motion full_order_motion(const Scene& scene) {
  FomSolver fom(scene);
  Motion run;
  std::vector<real_t> X, mass, volume;
  fom.reference(X, mass, volume);
  run.X.assign(X.begin(), X.end());
  run.mass.assign(mass.begin(), mass.end());
  run.volume.assign(volume.begin(), volume.end());
  for (int frame = 0; frame <= scene.num_outputs; ++frame) {
    fom.advance_to(scene.end_time * frame / scene.num_outputs);
    const ParticleFrame f = fom.frame();
    run.positions.emplace_back(f.x.begin(), f.x.end());
    run.velocities.emplace_back(f.v.begin(), f.v.end());
  }
  return run;
}

// The body's initial translation and spin as an affine rate: (v, [w]x) about its center c = 0.
std::vector<double> affine_rate(const Scene& scene) {
  const Vec3d& v = scene.bodies[0].velocity;
  const Vec3d& w = scene.bodies[0].angular_velocity;
  return {v[0], v[1], v[2], 0, -w[2], w[1], w[2], 0, -w[0], -w[1], w[0], 0};
}

RomResult affine_rollouts(const Scene& scene, const Motion& run, RomMethod method, int samples, int batch,
                          RomSettings settings = {}, double max_latent_speed = 0) {
  const std::size_t P = run.mass.size();
  settings.method = method;
  settings.samples = samples;
  std::vector<int> chosen(P);
  std::iota(chosen.begin(), chosen.end(), 0);
  if (samples > 0) {
    std::mt19937 gen(2);
    std::shuffle(chosen.begin(), chosen.end(), gen);
    chosen.resize(samples);
  }
  std::vector<double> motion;
  for (const auto& x : run.positions) motion.insert(motion.end(), x.begin(), x.end());
  std::vector<int> next(run.positions.size());  // one run: each configuration is followed by the next
  std::iota(next.begin(), next.end(), 1);
  next.back() = -1;
  const HyperReduction reduction = impl::hyper_reduction_from_motion(scene, settings, chosen, motion, P, next);
  const impl::ReferencePoints points{run.X, run.mass, run.volume};
  const AffineManifold manifold{{}, {0, 0, 0}};
  const std::vector<double> rate = affine_rate(scene);
  std::vector<double> xhat0, xhatdot0;
  std::vector<rom::RolloutLoads> loads;
  for (int b = 0; b < batch; ++b) {
    xhat0.insert(xhat0.end(), 12, 0.0);
    xhatdot0.insert(xhatdot0.end(), rate.begin(), rate.end());
    loads.push_back(impl::loads_for_scene(scene, points));
  }
  RomResult result;
  impl::step_batch(manifold, 12, points, scene, loads, xhat0, xhatdot0, settings, max_latent_speed, reduction, result,
                   {});
  return result;
}

// Largest deviation of the rollout's decoded positions and velocities from the given motion, over all frames.
std::pair<double, double> deviation(const RomResult& result, const Motion& motion) {
  const std::size_t P = motion.mass.size();
  double worst_x = 0, worst_v = 0;
  for (std::size_t f = 0; f < motion.positions.size(); ++f) {
    const double* xhat = &result.xhat[f * 12];
    const double* rate = &result.xhatdot[f * 12];
    for (std::size_t p = 0; p < P; ++p)
      for (int i = 0; i < 3; ++i) {
        double x = motion.X[3 * p + i] + xhat[i], v = rate[i];
        for (int j = 0; j < 3; ++j) {
          x += xhat[3 + 3 * i + j] * motion.X[3 * p + j];
          v += rate[3 + 3 * i + j] * motion.X[3 * p + j];
        }
        worst_x = std::max(worst_x, std::fabs(x - motion.positions[f][3 * p + i]));
        worst_v = std::max(worst_v, std::fabs(v - motion.velocities[f][3 * p + i]));
      }
  }
  return {worst_x, worst_v};
}

const std::vector<std::pair<RomMethod, int>> kConfigurations = {
    {RomMethod::MaterialPoint, 0}, {RomMethod::MaterialPoint, 16}, {RomMethod::SampleNode, 0},
    {RomMethod::SampleNode, 16},   {RomMethod::Galerkin, 0},       {RomMethod::Galerkin, 16}};
// Both projection schemes keep an exact manifold's motion: on an affine map the Gauss-Newton step is exact. (The
// Galerkin step takes the velocity scheme only.)
const std::vector<ProjectionScheme> kSchemes = {ProjectionScheme::Velocity, ProjectionScheme::Position};

// The Galerkin step's variants: grid 0 the continuum strain, 1 the grid strain and transfer, 2 the grid strain's node
// average; with the integrator.
RomSettings galerkin_variant(int grid, TimeIntegrator integrator) {
  RomSettings settings;
  settings.galerkin_strain = grid > 0 ? GalerkinStrain::Grid : GalerkinStrain::Continuum;
  settings.galerkin_transfer = grid == 1;
  settings.galerkin_node_average = grid == 2;
  settings.integrator = integrator;
  return settings;
}

std::string variant_label(const RomSettings& settings) {
  return std::string(settings.galerkin_transfer       ? " grid strain and transfer"
                     : settings.galerkin_node_average ? " grid strain, node average"
                                                      : "") +
         (settings.integrator == TimeIntegrator::Leapfrog ? " leapfrog" : "");
}

// Rolls the scene out in every configuration with every projection scheme it takes; check(label, dx, dv) judges
// each rollout's largest deviations from the motion.
template <class Check>
void check_every_configuration(const Scene& scene, const Motion& motion, Check check) {
  for (const auto& [method, samples] : kConfigurations)
    for (const ProjectionScheme scheme : kSchemes) {
      if (method == RomMethod::Galerkin && scheme != ProjectionScheme::Velocity) continue;
      // The Galerkin step also with the grid strain and the grid transfer, and with the grid strain's node average:
      // with every point only, since its test functions, like Algorithm 1's, pass a uniform field unchanged only
      // summed over the whole body (each node's average is a share of the body's mass), not sample by sample.
      // And with either integrator.
      for (const int grid : {0, 1, 2})
        for (const TimeIntegrator integrator : {TimeIntegrator::SymplecticEuler, TimeIntegrator::Leapfrog}) {
          if ((grid > 0 || integrator == TimeIntegrator::Leapfrog) && method != RomMethod::Galerkin) continue;
          if (grid == 2 && samples != 0) continue;
          if (grid == 1 && integrator == TimeIntegrator::Leapfrog) continue;  // refused (RomSettings::validate)
          RomSettings settings = galerkin_variant(grid, integrator);
          settings.projection = scheme;
          const RomResult result = affine_rollouts(scene, motion, method, samples, 1, settings);
          const std::string label =
              to_string(method) + " " + std::to_string(samples) + " " + to_string(scheme) + variant_label(settings);
          ASSERT_EQ(result.outcomes[0].flags & rom::fatal_flags, 0) << label << ": " << result.outcomes[0].message;
          const auto [dx, dv] = deviation(result, motion);
          check(label, dx, dv);
        }
    }
}

// Free fall: the full-order model is exact here (a uniform field passes the transfers unchanged), so the ROM must
// give the same velocities to rounding; positions may differ by the two time-step sequences, each within g t dt / 2
// of the parabola.
TEST(RomExactManifold, FreeFallMatchesTheFullOrderModel) {
  const Scene scene = affine_scene({0, 0, -9.81}, {0, 0, 0});
  const Motion fom = full_order_motion(scene);
  const double dt_max = scene.cfl * scene.dx / 0.2, t = scene.end_time;
  check_every_configuration(scene, fom, [&](const std::string& label, double dx, double dv) {
    EXPECT_LE(dv, 1e3 * eps) << label;  // ~100 steps of O(1) sums
    EXPECT_LE(dx, 9.81 * t * dt_max + 1e3 * eps) << label;
  });
}

// A spinning, translating box: its affine motion x = X + t (v + [w]x (X - c)) must be kept exactly: APIC with
// C = Fdot F^-1 carries the affine field through P2G and G2P unchanged and dg/dxhat does not depend on xhat, so
// xhatdot stays constant. (The full-order model drifts here at O(dt |grad v|^2): its C lags one step.)
TEST(RomExactManifold, AffineMotionIsKeptExactly) {
  const Scene scene = affine_scene({0, 0, 0}, {0.5, -1.0, 1.5});
  Motion exact = full_order_motion(scene);  // for the reference points; the frames are replaced below
  const std::vector<double> rate = affine_rate(scene);
  const std::size_t P = exact.mass.size();
  for (std::size_t f = 0; f < exact.positions.size(); ++f) {
    const double t = scene.end_time * double(f) / scene.num_outputs;
    for (std::size_t p = 0; p < P; ++p)
      for (int i = 0; i < 3; ++i) {
        double v = rate[i];
        for (int j = 0; j < 3; ++j) v += rate[3 + 3 * i + j] * exact.X[3 * p + j];
        exact.velocities[f][3 * p + i] = v;
        exact.positions[f][3 * p + i] = exact.X[3 * p + i] + t * v;
      }
  }
  // Rounding of the transfers and the 12 x 12 solve over a few steps (velocities O(1), positions O(0.1)), plus the
  // stiffness the test cannot switch off: accelerations below E / (rho dx), i.e. 2.4e-9 m/s over the run.
  const double stiffness = scene.material.youngs_modulus / (scene.material.density * scene.dx) * scene.end_time;
  check_every_configuration(scene, exact, [&](const std::string& label, double dx, double dv) {
    EXPECT_LE(dv, 1e4 * eps + stiffness) << label;
    EXPECT_LE(dx, 1e3 * eps + stiffness * scene.end_time) << label;
  });
}

// Leapfrog is exact for a constant acceleration (x_n+1 = x_n + dt v_n + dt^2 g / 2), so the Galerkin step with it
// keeps free fall on the parabola itself at every output time, to rounding, where symplectic Euler (and the
// full-order model) lag it by g t dt / 2.
TEST(RomExactManifold, LeapfrogFallsOnTheParabola) {
  const Scene scene = affine_scene({0, 0, -9.81}, {0, 0, 0});
  Motion exact = full_order_motion(scene);  // for the reference points; the frames are replaced below
  const Vec3d& v0 = scene.bodies[0].velocity;
  for (std::size_t f = 0; f < exact.positions.size(); ++f) {
    const double t = scene.end_time * double(f) / scene.num_outputs;
    for (std::size_t p = 0; p < exact.mass.size(); ++p)
      for (int i = 0; i < 3; ++i) {
        exact.velocities[f][3 * p + i] = v0[i] + scene.gravity[i] * t;
        exact.positions[f][3 * p + i] = exact.X[3 * p + i] + v0[i] * t + 0.5 * scene.gravity[i] * t * t;
      }
  }
  for (const int samples : {0, 16})
    for (const int grid : {0, 1, 2}) {
      if (grid == 2 && samples != 0) continue;  // its samples pass a uniform load only summed over the body
      const RomSettings settings = galerkin_variant(grid, TimeIntegrator::Leapfrog);
      const RomResult result = affine_rollouts(scene, exact, RomMethod::Galerkin, samples, 1, settings);
      const std::string label = std::to_string(samples) + variant_label(settings);
      ASSERT_EQ(result.outcomes[0].flags & rom::fatal_flags, 0) << label << ": " << result.outcomes[0].message;
      const auto [dx, dv] = deviation(result, exact);
      // Rounding of ~100 steps of O(1) sums and the 12 x 12 solves, as in free fall against the full-order model.
      EXPECT_LE(dv, 1e3 * eps) << label;
      EXPECT_LE(dx, 1e3 * eps) << label;
    }
}

TEST(RomBatch, IdenticalRolloutsGiveIdenticalResults) {
  const Scene scene = affine_scene({0, 0, -9.81}, {0.5, -1.0, 1.5});
  const Motion run = full_order_motion(scene);
  for (const RomMethod method : {RomMethod::MaterialPoint, RomMethod::SampleNode}) {
    const RomResult result = affine_rollouts(scene, run, method, 16, 5);
    const std::size_t per_rollout = result.xhat.size() / 5;
    for (int b = 1; b < 5; ++b)
      for (std::size_t i = 0; i < per_rollout; ++i) {
        ASSERT_EQ(result.xhat[b * per_rollout + i], result.xhat[i]) << "rollout " << b;
        ASSERT_EQ(result.xhatdot[b * per_rollout + i], result.xhatdot[i]) << "rollout " << b;
      }
  }
}

// --end-time: a shorter horizon keeps the scene's output times, and its rollout is the longer one's first frames.
TEST(RomHorizon, ShorterHorizonIsAPrefixOfTheFullRollout) {
  const Scene scene = affine_scene({0, 0, -9.81}, {0.5, -1.0, 1.5});
  const Motion run = full_order_motion(scene);
  Scene shorter = scene;
  const double interval = scene.end_time / scene.num_outputs;
  impl::apply_horizon(shorter, 1.6 * interval);  // rounds to 2 intervals
  ASSERT_EQ(shorter.num_outputs, 2);
  for (const RomMethod method : {RomMethod::MaterialPoint, RomMethod::SampleNode}) {
    const RomResult full = affine_rollouts(scene, run, method, 16, 1);
    const RomResult part = affine_rollouts(shorter, run, method, 16, 1);
    ASSERT_EQ(part.times.size(), 3u);
    for (std::size_t f = 0; f < part.times.size(); ++f)
      EXPECT_NEAR(part.times[f], full.times[f], 1e-12 * scene.end_time) << "frame " << f;
    for (std::size_t i = 0; i < part.xhat.size(); ++i) {
      ASSERT_EQ(part.xhat[i], full.xhat[i]) << to_string(method) << " entry " << i;
      ASSERT_EQ(part.xhatdot[i], full.xhatdot[i]) << to_string(method) << " entry " << i;
    }
  }
}

// A horizon of more output intervals than an int holds is refused, not converted (undefined behaviour).
TEST(RomHorizon, HorizonBeyondTheIntRangeIsRefused) {
  Scene scene = affine_scene({0, 0, -9.81}, {0.5, -1.0, 1.5});
  const double interval = scene.end_time / scene.num_outputs;
  try {
    impl::apply_horizon(scene, 3e9 * interval);
    ADD_FAILURE() << "a horizon of 3e9 output intervals was accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_EQ(std::string(error.what()),
              "--end-time, in output intervals of the scene, must be a whole number in [1, 2147483647], not "
              "3000000000");
  }
}

// ---------------------------------------------------------------------------------------------------------------
// Detectors (docs/stability.md): each constructed case stops the rollout before its end with the documented cause;
// the stopped rollout keeps its last good (finite) state and reports where it stopped.
void expect_stopped_by(const RomResult& result, int flag, const std::string& cause) {
  const RolloutOutcome& o = result.outcomes[0];
  EXPECT_TRUE(o.flags & flag) << o.message;
  EXPECT_GE(o.frames_completed, 1);
  EXPECT_LT(o.frames_completed, int(result.times.size()));
  EXPECT_GT(o.stopped_at, 0);
  EXPECT_NE(o.message.find(cause), std::string::npos) << o.message;
  // one line, saying what to change: an option of `mpmrom rollout` in brackets after the cause
  EXPECT_EQ(o.message.find('\n'), std::string::npos) << o.message;
  EXPECT_NE(o.message.find(" (", o.message.find(cause) + cause.size()), std::string::npos) << o.message;
  EXPECT_NE(o.message.find("--"), std::string::npos) << o.message;
  for (const double value : result.xhat) ASSERT_TRUE(std::isfinite(value));
  for (const double value : result.xhatdot) ASSERT_TRUE(std::isfinite(value));
}

TEST(RomDetectors, LatentSpeedAboveTheLimitIsAnEnergyBlowUp) {
  const Scene scene = affine_scene({0, 0, 0}, {0.5, -1.0, 1.5});
  const Motion run = full_order_motion(scene);
  double speed = 0;
  for (const double rate : affine_rate(scene)) speed += rate * rate;
  // The exact motion keeps |xhatdot| = |rate|: a limit of half that trips at the first step, twice it never does.
  for (const RomMethod method : {RomMethod::MaterialPoint, RomMethod::SampleNode}) {
    expect_stopped_by(affine_rollouts(scene, run, method, 16, 1, {}, 0.5 * std::sqrt(speed)), rom::flag_energy,
                      "energy blow-up");
    EXPECT_EQ(affine_rollouts(scene, run, method, 16, 1, {}, 2 * std::sqrt(speed)).outcomes[0].flags & rom::fatal_flags,
              0);
  }
}

TEST(RomDetectors, IllConditionedProjectionStopsWhenRegularisationIsOff) {
  const Scene scene = affine_scene({0, 0, -9.81}, {0, 0, 0});
  const Motion run = full_order_motion(scene);
  // Two sample points give 6 equations for 12 unknowns: J^T J is singular.
  RomSettings off;
  off.regularize = false;
  expect_stopped_by(affine_rollouts(scene, run, RomMethod::MaterialPoint, 2, 1, off), rom::flag_ill_posed,
                    "ill-conditioned normal equations");
  // The default regularises instead, counts it, and goes on.
  const RomResult on = affine_rollouts(scene, run, RomMethod::MaterialPoint, 2, 1);
  EXPECT_EQ(on.outcomes[0].flags & rom::fatal_flags, 0) << on.outcomes[0].message;
  EXPECT_GT(on.outcomes[0].regularized_steps, 0);
}

// A node set built from the first configuration only, with no margin, misses the stencils the translating box
// reaches later (it moves 0.48 cells in x over the run): the first sample to cross a half-cell boundary stops it.
TEST(RomDetectors, SamplePointLeavingTheNodeSetStops) {
  const Scene scene = affine_scene({0, 0, 0}, {0, 0, 0});
  const Motion run = full_order_motion(scene);
  Motion first_frame_only = run;
  first_frame_only.positions.resize(1);
  RomSettings tight;
  tight.envelope_margin = 0;
  for (const RomMethod method : {RomMethod::MaterialPoint, RomMethod::SampleNode}) {
    expect_stopped_by(affine_rollouts(scene, first_frame_only, method, 16, 1, tight), rom::flag_left_node_set,
                      "left the precomputed node set");
    // The whole motion's node set keeps the same rollout going to the end.
    EXPECT_EQ(affine_rollouts(scene, run, method, 16, 1, tight).outcomes[0].flags & rom::fatal_flags, 0);
  }
}

TEST(RomDetectors, FailedInversionsAboveTheLimitStopAlgorithm2) {
  const Scene scene = affine_scene({0, 0, -9.81}, {0, 0, 0});
  const Motion run = full_order_motion(scene);
  // A tolerance below rounding (1e-30 cells) fails every inversion once the map is no longer the identity (at
  // xhat = 0, the first step, the residual is exactly zero), and the rollout stops soon after.
  RomSettings strict;
  strict.newton_tolerance = 1e-30;
  const RomResult with_fallback = affine_rollouts(scene, run, RomMethod::SampleNode, 16, 1, strict);
  expect_stopped_by(with_fallback, rom::flag_inversion, "inversion failed");
  // The fallback kept every failed point on the material point it found in the first step.
  EXPECT_GT(with_fallback.outcomes[0].inversion_failures, 0);
  EXPECT_EQ(with_fallback.outcomes[0].inversion_fallbacks, with_fallback.outcomes[0].inversion_failures);
  strict.inversion_fallback = false;
  const RomResult without = affine_rollouts(scene, run, RomMethod::SampleNode, 16, 1, strict);
  expect_stopped_by(without, rom::flag_inversion, "inversion failed");
  EXPECT_EQ(without.outcomes[0].inversion_fallbacks, 0);
}

}  // namespace
}  // namespace mpmrom::test
