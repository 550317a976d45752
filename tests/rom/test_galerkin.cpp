// The Galerkin step's reduced force (rom/kernels/galerkin.hpp): minus the gradient of the samples' elastic energy,
// checked against central differences of that energy, plus the loads' generalised force, with the manifold's own
// strain and with the grid strain; and the grid strain's stencils (rom/detail/grid_strain.cpp) on a lattice.
#include <gtest/gtest.h>

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "rom/detail/grid_strain.hpp"
#include "rom/kernels/galerkin.hpp"
#include "rom/kernels/sources.hpp"

namespace mpmrom::test {
namespace {

// A bending and stretching map, g = (X + a X_z^2, Y + b X_z^2, Z + c X_z) for xhat = (a, b, c): F depends on X and
// xhat, so the elastic energy is a non-quadratic function of xhat.
struct BendingManifold : rom::TeamFromSerial<BendingManifold> {
  KOKKOS_INLINE_FUNCTION int latent_dim() const { return 3; }
  KOKKOS_INLINE_FUNCTION void position_and_gradient(const real_t X[3], const real_t* xhat, real_t g[3],
                                                    real_t F[3][3]) const {
    g[0] = X[0] + xhat[0] * X[2] * X[2];
    g[1] = X[1] + xhat[1] * X[2] * X[2];
    g[2] = X[2] + xhat[2] * X[2];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) F[i][j] = i == j ? real_t(1) : real_t(0);
    F[0][2] = 2 * xhat[0] * X[2];
    F[1][2] = 2 * xhat[1] * X[2];
    F[2][2] += xhat[2];
  }
  KOKKOS_INLINE_FUNCTION void kinematics(const real_t X[3], const real_t* xhat, const real_t* rate,
                                         nn::PointKinematics<real_t>& out, real_t* dgdxhat) const {
    position_and_gradient(X, xhat, out.g, out.F);
    const real_t column[3] = {X[2] * X[2], X[2] * X[2], X[2]};  // dg_i/dxhat_i; dg/dxhat is diagonal
    for (int i = 0; i < 3; ++i) {
      out.v[i] = column[i] * rate[i];
      for (int j = 0; j < 3; ++j) out.Fdot[i][j] = real_t(0);
    }
    out.Fdot[0][2] = 2 * rate[0] * X[2];
    out.Fdot[1][2] = 2 * rate[1] * X[2];
    out.Fdot[2][2] = rate[2];
    if (dgdxhat == nullptr) return;
    for (int i = 0; i < 3; ++i)
      for (int q = 0; q < 3; ++q) dgdxhat[i * 3 + q] = i == q ? column[i] : real_t(0);
  }
};

// The samples' elastic energy sum_s V0_s psi(F_s(xhat)), in double.
double elastic_energy(const std::vector<double>& X, const std::vector<double>& volume, const double xhat[3],
                      const ElasticMaterial<double>& material) {
  double energy = 0;
  for (std::size_t s = 0; s < volume.size(); ++s) {
    const double Z = X[3 * s + 2];
    Mat3<double> F = Mat3<double>::identity();
    F(0, 2) = 2 * xhat[0] * Z;
    F(1, 2) = 2 * xhat[1] * Z;
    F(2, 2) += xhat[2];
    energy += volume[s] * energy_density(material, F);
  }
  return energy;
}

// The grid strain of one sample: F = I + sum_n u_n (x) grad N_n(X_s) over its stencil rows (grid_strain_nodes'
// layout), each node displaced as the bending map moves its centroid where the row leaves the axis free.
Mat3<double> grid_strain(const double Xs[3], const double* rows, const GridGeometry<real_t>& grid,
                         const double xhat[3]) {
  const auto stencil =
      quadratic_stencil(Vec3<double>{{Xs[0], Xs[1], Xs[2]}},
                        Vec3<double>{{grid.origin[0], grid.origin[1], grid.origin[2]}}, 1 / double(grid.dx));
  Mat3<double> F = Mat3<double>::identity();
  for (int n = 0; n < 27; ++n) {
    const double* row = rows + n * impl::grid_strain_node_values;
    const double u[3] = {xhat[0] * row[2] * row[2], xhat[1] * row[2] * row[2], xhat[2] * row[2]};
    const Vec3<double> grad = stencil.gradient(n / 9, (n / 3) % 3, n % 3);
    for (int a = 0; a < 3; ++a)
      for (int c = 0; c < 3; ++c) F(a, c) += row[3 + a] * u[a] * grad[c];
  }
  return F;
}

// The samples' elastic energy sum_s V0_s psi(F_s(xhat)) with the grid strain, in double.
double grid_elastic_energy(const std::vector<double>& X, const std::vector<double>& volume,
                           const std::vector<double>& rows, const GridGeometry<real_t>& grid, const double xhat[3],
                           const ElasticMaterial<double>& material) {
  double energy = 0;
  for (std::size_t s = 0; s < volume.size(); ++s) {
    const double* stencil_rows = &rows[s * 27 * impl::grid_strain_node_values];
    energy += volume[s] * energy_density(material, grid_strain(&X[3 * s], stencil_rows, grid, xhat));
  }
  return energy;
}

// Six samples of the bending map under gravity and a force on the points above z = 0.25.
class GalerkinForce : public ::testing::Test {
 protected:
  static constexpr int S = 6, r = 3;
  const double density = 100, xhat_host[r] = {0.4, -0.3, 0.2};
  const std::vector<double> X = {0.1,  0,    0.05, -0.1,  0.05, 0.2, 0, -0.1, 0.35,
                                 0.05, 0.05, 0.4,  -0.05, 0,    0.1, 0, 0,    0.3};
  std::vector<double> mass = std::vector<double>(S), volume = std::vector<double>(S);
  const ElasticMaterial<real_t> material = elastic_material(ElasticModel::FixedCorotated, real_t(12500), real_t(0.3));
  const ElasticMaterial<double> material_double{material.model, double(material.mu), double(material.lambda)};
  const GridGeometry<real_t> grid{{{real_t(-0.5), real_t(-0.5), real_t(-0.5)}}, real_t(0.05), real_t(20), {21, 21, 21}};

  void SetUp() override {
    for (int s = 0; s < S; ++s) mass[s] = 0.01 * (1 + s), volume[s] = mass[s] / density;
  }

  // The kernel's reduced force per unit mass at each sample (S * r), with the grid strain when rows are given;
  // on_teams: then again by TeamGalerkinSampleTerms (a team per sample) from the samples' kinematics the first pass
  // left.
  std::vector<double> reduced_forces(const std::vector<double>& rows, bool on_teams = false,
                                     bool node_average = false) const {
    using ExecutionSpace = Kokkos::DefaultExecutionSpace;
    using MemorySpace = ExecutionSpace::memory_space;
    rom::RolloutLoads load{};
    load.gravity = {{0, 0, real_t(-9.81)}};
    load.num_forces = 1;  // (1, 2, 3) N/kg on the points above z = 0.25, during [0, 1)
    const real_t box[6] = {-1, -1, real_t(0.25), 1, 1, 1}, per_mass[3] = {1, 2, 3};
    for (int d = 0; d < 6; ++d) load.force_box[d] = box[d];
    for (int d = 0; d < 3; ++d) load.force_per_mass[d] = per_mass[d];
    load.force_window[0] = 0;
    load.force_window[1] = 1;

    Kokkos::View<real_t**, Kokkos::LayoutRight, MemorySpace> Xv("X", S, 3);
    rom::BatchMatrix<MemorySpace> xhat("xhat", 1, r), xhatdot("xhatdot", 1, r), force("force", 1, S * r);
    Kokkos::View<rom::RolloutLoads*, MemorySpace> loads("loads", 1);
    rom::BatchVectors<MemorySpace> x("x", 1, S, 3), v("v", 1, S, 3);
    rom::BatchJacobians<MemorySpace> J("J", 1, S, 3, r);
    Kokkos::View<int*, MemorySpace> flags("flags", 1);
    // Every (sample, stencil node) its own node here: the kernels must not care whether samples share nodes.
    const int num_nodes = rows.empty() ? 0 : S * 27;
    Kokkos::View<real_t**, Kokkos::LayoutRight, MemorySpace> nodes("nodes", num_nodes, impl::grid_strain_node_values);
    Kokkos::View<int**, Kokkos::LayoutRight, MemorySpace> stencils("stencils", rows.empty() ? 0 : S, 27);
    rom::BatchVectors<MemorySpace> node_u("node_u", 1, num_nodes, 3);
    rom::BatchJacobians<MemorySpace> node_dg("node_dg", 1, num_nodes, 3, r);
    {
      auto hX = Kokkos::create_mirror_view(Xv);
      for (int s = 0; s < S; ++s)
        for (int d = 0; d < 3; ++d) hX(s, d) = real_t(X[3 * s + d]);
      Kokkos::deep_copy(Xv, hX);
      auto hxhat = Kokkos::create_mirror_view(xhat);
      for (int q = 0; q < r; ++q) hxhat(0, q) = real_t(xhat_host[q]);
      Kokkos::deep_copy(xhat, hxhat);
      auto hloads = Kokkos::create_mirror_view(loads);
      hloads(0) = load;
      Kokkos::deep_copy(loads, hloads);
      auto hnodes = Kokkos::create_mirror_view(nodes);
      for (std::size_t i = 0; i < hnodes.size(); ++i) hnodes.data()[i] = real_t(rows[i]);
      Kokkos::deep_copy(nodes, hnodes);
      auto hstencils = Kokkos::create_mirror_view(stencils);
      for (std::size_t i = 0; i < hstencils.size(); ++i) hstencils.data()[i] = int(i);
      Kokkos::deep_copy(stencils, hstencils);
    }
    Kokkos::parallel_for(Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(0, num_nodes),
                         rom::GridStrainNodeKinematics<BendingManifold, MemorySpace>{BendingManifold{}, nodes, xhat,
                                                                                     node_u, node_dg, flags});
    real_t fastest = 0;
    rom::GalerkinSampleTerms<BendingManifold, MemorySpace> terms{BendingManifold{},
                                                                 Xv,
                                                                 xhat,
                                                                 xhatdot,
                                                                 loads,
                                                                 material,
                                                                 real_t(density),
                                                                 real_t(0.5),
                                                                 x,
                                                                 v,
                                                                 J,
                                                                 force,
                                                                 flags,
                                                                 stencils,
                                                                 node_u,
                                                                 node_dg,
                                                                 grid};
    terms.node_average = node_average;
    Kokkos::parallel_reduce(Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(0, S), terms,
                            Kokkos::Max<real_t>(fastest));
    if (on_teams) {
      using TeamTerms = rom::TeamGalerkinSampleTerms<BendingManifold, ExecutionSpace>;
      Kokkos::deep_copy(force, real_t(0));
      terms.kinematics_given = true;
      Kokkos::parallel_reduce(Kokkos::TeamPolicy<ExecutionSpace>(S, Kokkos::AUTO)
                                  .set_scratch_size(0, Kokkos::PerTeam(TeamTerms::scratch_bytes())),
                              TeamTerms{terms}, Kokkos::Max<real_t>(fastest));
    }
    EXPECT_EQ(Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), flags)(0), 0);
    const auto q = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), force);
    return std::vector<double>(q.data(), q.data() + q.size());
  }

  // The reduced force against minus the central differences of energy(xhat) plus the loads' generalised force.
  // Central differences in double: truncation h^2 |E'''| / 6 and rounding eps_d |E| / h, both below 1e-9 of the
  // force at h = 1e-5 on this O(1) strain; the kernel's own rounding in real_t is a few hundred eps of the terms.
  template <class Energy>
  void expect_energy_gradient(const std::vector<double>& q, const Energy& energy) const {
    const double h = 1e-5, eps = std::numeric_limits<real_t>::epsilon();
    for (int k = 0; k < r; ++k) {
      double plus[r], minus[r];
      for (int i = 0; i < r; ++i) plus[i] = minus[i] = xhat_host[i];
      plus[k] += h;
      minus[k] -= h;
      double expected = -(energy(plus) - energy(minus)) / (2 * h);
      double computed = 0, scale = std::fabs(expected);
      for (int s = 0; s < S; ++s) {
        const double Z = X[3 * s + 2], column[3] = {Z * Z, Z * Z, Z};
        const double body[3] = {Z >= 0.25 ? 1.0 : 0.0, Z >= 0.25 ? 2.0 : 0.0, (Z >= 0.25 ? 3.0 : 0.0) - 9.81};
        expected += mass[s] * column[k] * body[k];
        computed += mass[s] * q[std::size_t(s * r + k)];
        scale += mass[s] * std::fabs(column[k] * body[k]);
      }
      EXPECT_NEAR(computed, expected, (1e-9 + 300 * eps) * scale) << "xhat component " << k;
    }
  }
};

TEST_F(GalerkinForce, ReducedForceIsMinusTheEnergyGradientPlusTheLoads) {
  expect_energy_gradient(reduced_forces({}),
                         [&](const double* xhat) { return elastic_energy(X, volume, xhat, material_double); });
}

// Any centroids and held axes: the grid strain's force is still the gradient of its energy.
TEST_F(GalerkinForce, GridStrainForceIsMinusItsEnergyGradientPlusTheLoads) {
  std::vector<double> rows(std::size_t(S) * 27 * impl::grid_strain_node_values);
  for (std::size_t i = 0; i < rows.size() / impl::grid_strain_node_values; ++i) {
    double* row = &rows[i * impl::grid_strain_node_values];
    const std::size_t s = i / 27;
    for (int d = 0; d < 3; ++d) row[d] = X[3 * s + d] + 0.01 * std::sin(double(7 * i + d));  // a centroid nearby
    for (int d = 0; d < 3; ++d) row[3 + d] = (i + d) % 5 == 0 ? 0 : 1;                       // some axes held
    for (int d = 0; d < 3; ++d) row[6 + d] = row[d];  // the test function where the node moves: an energy's
  }
  expect_energy_gradient(reduced_forces(rows), [&](const double* xhat) {
    return grid_elastic_energy(X, volume, rows, grid, xhat, material_double);
  });
  // The team form sums each entry of F and dF/dxhat in the one-thread order: equal up to the contraction of its
  // multiply-adds, a few eps of the force's terms (O(1) here).
  const std::vector<double> one_thread = reduced_forces(rows), on_teams = reduced_forces(rows, true);
  for (std::size_t e = 0; e < one_thread.size(); ++e)
    EXPECT_NEAR(on_teams[e], one_thread[e],
                16 * std::numeric_limits<real_t>::epsilon() * (1 + std::fabs(one_thread[e])))
        << "entry " << e;
}

// With the node average the stress and the loads work against test functions taken elsewhere than where the nodes
// move (rows 6-8): per sample, minus the derivative of its energy along the strain those test functions give, plus the
// loads against their interpolation sum_n N_n(X_s) dg/dxhat(row 6-8 of n); no energy's gradient (Petrov-Galerkin).
TEST_F(GalerkinForce, NodeAverageWorksAgainstItsTestFunctions) {
  std::vector<double> rows(std::size_t(S) * 27 * impl::grid_strain_node_values), test_rows(rows.size());
  for (std::size_t i = 0; i < rows.size() / impl::grid_strain_node_values; ++i) {
    double* row = &rows[i * impl::grid_strain_node_values];
    const std::size_t s = i / 27;
    for (int d = 0; d < 3; ++d) row[d] = X[3 * s + d] + 0.01 * std::sin(double(7 * i + d));
    for (int d = 0; d < 3; ++d) row[3 + d] = (i + d) % 5 == 0 ? 0 : 1;
    for (int d = 0; d < 3; ++d) row[6 + d] = row[d] + 0.03 * std::cos(double(5 * i + d));  // a centroid elsewhere
    std::copy(row, row + impl::grid_strain_node_values, &test_rows[i * impl::grid_strain_node_values]);
    for (int d = 0; d < 3; ++d) test_rows[i * impl::grid_strain_node_values + d] = row[6 + d];
  }
  const std::vector<double> q = reduced_forces(rows, false, true);
  const double h = 1e-5, eps = std::numeric_limits<real_t>::epsilon();
  for (int s = 0; s < S; ++s) {
    const double* strain_rows = &rows[std::size_t(s) * 27 * impl::grid_strain_node_values];
    const double* tests = &test_rows[std::size_t(s) * 27 * impl::grid_strain_node_values];
    const Mat3<double> F = grid_strain(&X[3 * s], strain_rows, grid, xhat_host);
    const auto stencil =
        quadratic_stencil(Vec3<double>{{X[3 * s], X[3 * s + 1], X[3 * s + 2]}},
                          Vec3<double>{{grid.origin[0], grid.origin[1], grid.origin[2]}}, 1 / double(grid.dx));
    const double Z = X[3 * s + 2];
    const double body[3] = {Z >= 0.25 ? 1.0 : 0.0, Z >= 0.25 ? 2.0 : 0.0, (Z >= 0.25 ? 3.0 : 0.0) - 9.81};
    for (int k = 0; k < r; ++k) {
      double unit[r] = {0, 0, 0};
      unit[k] = 1;  // the bending map's u is linear in xhat: its strain at a unit xhat is dF/dxhat_k
      Mat3<double> dF = grid_strain(&X[3 * s], tests, grid, unit), plus = F, minus = F;
      for (int a = 0; a < 3; ++a) dF(a, a) -= 1;
      for (int a = 0; a < 3; ++a)
        for (int c = 0; c < 3; ++c) plus(a, c) += h * dF(a, c), minus(a, c) -= h * dF(a, c);
      const double elastic =
          -volume[s] * (energy_density(material_double, plus) - energy_density(material_double, minus)) / (2 * h);
      double load = 0;  // the loads against the interpolated test functions (u_k = z^2, z^2, z along axis k)
      for (int n = 0; n < 27; ++n) {
        const double* row = tests + n * impl::grid_strain_node_values;
        load += stencil.weight(n / 9, (n / 3) % 3, n % 3) * row[3 + k] * (k < 2 ? row[2] * row[2] : row[2]) * body[k];
      }
      // Per sample, no sum to average over: the central difference's truncation and rounding (each ~1e-9 of the
      // terms at h = 1e-5, expect_energy_gradient) get 1e-8. The kernel's rounding in real_t: F sums 27 node terms
      // each larger than F - I, P comes from a 3 x 3 SVD, and P : dF cancels among its 9 terms, so a sample's force
      // carries ~1e3 eps of it (measured in float: up to 9e-5 relative, 750 eps); 2000 eps leaves room, and a
      // wrong test function or load weight moves the force by ~1e-2 of it.
      const double expected = elastic + mass[s] * load, scale = std::fabs(elastic) + mass[s] * std::fabs(load);
      EXPECT_NEAR(mass[s] * q[std::size_t(s * r + k)], expected, (1e-8 + 2000 * eps) * scale)
          << "sample " << s << ", xhat component " << k;
    }
  }
}

// The grid strain's entries (F, then dF/dxhat) at X on `grid` from made-up stencil nodes, with r a compile-time
// constant (row 0: dF in registers) and bounded by r at run time (row 1: dF in local memory, what latent dimensions
// above galerkin_register_latent_dim take). A free function: CUDA's lambdas may not live in a test's body.
template <int r>
std::vector<double> grid_strain_both_ways(const GridGeometry<real_t>& grid, const real_t X0, const real_t X1,
                                          const real_t X2) {
  using ExecutionSpace = Kokkos::DefaultExecutionSpace;
  using MemorySpace = ExecutionSpace::memory_space;
  constexpr int num_nodes = 27, entries = 9 * (r + 1);
  const Kokkos::View<int**, Kokkos::LayoutRight, MemorySpace> stencils("stencils", 1, 27);
  const rom::BatchVectors<MemorySpace> node_u("node_u", 1, num_nodes, 3);
  const rom::BatchJacobians<MemorySpace> node_dg("node_dg", 1, num_nodes, 3, r);
  rom::GalerkinSampleTerms<BendingManifold, MemorySpace> terms{};
  terms.xhat = rom::BatchMatrix<MemorySpace>("xhat", 1, r);
  terms.stencils = stencils;
  terms.node_u = node_u;
  terms.node_dg = node_dg;
  terms.grid = grid;
  Kokkos::parallel_for(
      Kokkos::RangePolicy<ExecutionSpace>(0, num_nodes), KOKKOS_LAMBDA(const int i) {
        stencils(0, i) = num_nodes - 1 - i;  // any order of the stencil's nodes
        for (int a = 0; a < 3; ++a) {
          node_u(0, i, a) = real_t(0.01) * real_t((7 * i + a) % 11 - 5);
          for (int k = 0; k < r; ++k) node_dg(0, i, a, k) = real_t(0.1) * real_t((3 * i + 5 * a + k) % 7 - 3);
        }
      });
  Kokkos::View<real_t**, MemorySpace> sums("sums", 2, entries);
  Kokkos::parallel_for(
      Kokkos::RangePolicy<ExecutionSpace>(0, 1), KOKKOS_LAMBDA(const int) {
        const real_t Xs[3] = {X0, X1, X2};
        const QuadraticStencil<real_t> stencil = terms.sample_stencil(Xs);
        Mat3<real_t> F, dF[r], F_any, dF_any[rom::max_latent_dim];
        terms.template grid_strain<r>(0, 0, stencil, F, dF);
        terms.template grid_strain<rom::max_latent_dim>(0, 0, stencil, F_any, dF_any);
        for (int e = 0; e < entries; ++e) {
          sums(0, e) = (e < 9 ? F : dF[e / 9 - 1])(e % 9 / 3, e % 3);
          sums(1, e) = (e < 9 ? F_any : dF_any[e / 9 - 1])(e % 9 / 3, e % 3);
        }
      });
  const auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), sums);
  std::vector<double> out;
  for (int row = 0; row < 2; ++row)
    for (int e = 0; e < entries; ++e) out.push_back(double(host(row, e)));
  return out;
}

// Both forms of the grid strain's sums run the same sums in the same order; only the compiler's contraction of their
// multiply-adds into fused ones may differ (it does in float). Each entry sums 27 products of at most 0.3 x 20 (a
// made-up node value times a B-spline gradient at dx = 0.05) and a fused multiply-add moves each product's rounding
// by at most eps of it: 27 x 6 eps, 162 eps; 256 eps leaves room, a missing or doubled term moves an entry by ~1e-2.
// And with_latent_dim hands each r its own instance up to its bound, the runtime-bounded one above it.
TEST_F(GalerkinForce, GridStrainSumsAreTheSameWithACompileTimeOrARunTimeLatentDimension) {
  const std::vector<double> sums = grid_strain_both_ways<r>(grid, real_t(X[0]), real_t(X[1]), real_t(X[2]));
  const std::size_t entries = sums.size() / 2;
  const double eps = std::numeric_limits<real_t>::epsilon();
  for (std::size_t e = 0; e < entries; ++e) EXPECT_NEAR(sums[entries + e], sums[e], 256 * eps) << "entry " << e;
  for (int latent = 1; latent <= rom::max_latent_dim; ++latent) {
    int given = 0;
    rom::with_latent_dim<rom::galerkin_register_latent_dim>(latent, [&](auto R) { given = decltype(R)::value; });
    EXPECT_EQ(given, latent <= rom::galerkin_register_latent_dim ? latent : rom::max_latent_dim) << latent;
  }
}

// Two launches' outputs equal to the bit.
template <class View>
void expect_same(const View& expected, const View& computed, const char* what) {
  const auto e = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), expected);
  const auto c = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), computed);
  for (std::size_t i = 0; i < e.size(); ++i) EXPECT_EQ(c.data()[i], e.data()[i]) << what << " entry " << i;
}

// Grid strain node rows (nodes, 9) of the launch tests: positions, held axes, and the test points at the nodes or,
// with centroids, off them for every other node (as the node average's centroids beyond a free surface).
template <class HostRows>
void fill_strain_node_rows(const HostRows& rows, bool centroids) {
  for (int i = 0; i < int(rows.extent(0)); ++i)
    for (int d = 0; d < 3; ++d) {
      rows(i, d) = rows(i, 6 + d) = real_t(0.1 * std::sin(double(3 * i + d)));
      if (centroids && i % 2 == 1) rows(i, 6 + d) -= real_t(0.02 * (d + 1));
      rows(i, 3 + d) = (i + d) % 4 == 0 ? 0 : 1;
    }
}

// The grid strain's nodes on teams with the node average (two passes of the network a team thread, GPUs' small
// batches) give what one thread a node gives: teams of up to 4 one-lane threads over 3 rollouts of 7 nodes, so that
// the last team has threads past the last item; equal to the bit. (Both passes must work in one scratch block:
// a second block came back null for a trained network's team scratch on an H200; the analytic map's small scratch
// leaves room for a second block on the CPU and the H200 alike, so this test does not see that fault.)
TEST_F(GalerkinForce, TeamNodesWithTheNodeAverageMatchOneThreadANode) {
  using ExecutionSpace = Kokkos::DefaultExecutionSpace;
  using MemorySpace = ExecutionSpace::memory_space;
  using Nodes = rom::TeamGridStrainNodeKinematics<BendingManifold, ExecutionSpace>;
  const int B = 3, N = 7;
  Kokkos::View<real_t**, Kokkos::LayoutRight, MemorySpace> nodes("nodes", N, 9);
  rom::BatchMatrix<MemorySpace> xhat("xhat", B, r);
  Kokkos::View<int*, MemorySpace> flags("flags", B);
  auto hnodes = Kokkos::create_mirror_view(nodes);
  auto hxhat = Kokkos::create_mirror_view(xhat);
  fill_strain_node_rows(hnodes, true);
  for (int b = 0; b < B; ++b)
    for (int q = 0; q < r; ++q) hxhat(b, q) = real_t(xhat_host[q] * (1 + b));
  Kokkos::deep_copy(nodes, hnodes);
  Kokkos::deep_copy(xhat, hxhat);
  rom::BatchVectors<MemorySpace> u("u", B, N, 3), team_u("team u", B, N, 3);
  rom::BatchJacobians<MemorySpace> dg("dg", B, N, 3, r), team_dg("team dg", B, N, 3, r);
  Kokkos::parallel_for(
      Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(0, B * N),
      rom::GridStrainNodeKinematics<BendingManifold, MemorySpace>{BendingManifold{}, nodes, xhat, u, dg, flags});
  const rom::TeamScratch scratch =
      rom::SampleKinematics<BendingManifold, ExecutionSpace>::scratch_for(BendingManifold{});
  const Nodes probe{BendingManifold{}, nodes, xhat, team_u, team_dg, rom::TeamShape{}, scratch, true};
  const int most = Kokkos::TeamPolicy<ExecutionSpace>(1, 1).team_size_max(probe, Kokkos::ParallelForTag());
  const rom::TeamShape shape{std::min(4, most), 1, 1};
  Kokkos::parallel_for(
      Kokkos::TeamPolicy<ExecutionSpace>((B * N + shape.threads - 1) / shape.threads, shape.threads, shape.lanes)
          .set_scratch_size(0, Kokkos::PerTeam(scratch.bytes(shape))),
      Nodes{BendingManifold{}, nodes, xhat, team_u, team_dg, shape, scratch, true});
  expect_same(u, team_u, "node displacement");
  expect_same(dg, team_dg, "node dg/dxhat at the test point");
}

// The grid strain's nodes and the samples in blocks of points (CPUs) give what one thread an item gives: 3 rollouts
// of 7 nodes (and of the fixture's samples), so that blocks straddle rollouts and the last block is part padding;
// every other node's test point off the node (the node average's second pass), and the second rollout stopped, whose
// nodes the launch must leave as they were. The analytic map's block runs its one-point arithmetic a lane: equal to
// the bit.
TEST_F(GalerkinForce, BlockLaunchesMatchOneThreadAnItem) {
  using ExecutionSpace = Kokkos::DefaultHostExecutionSpace;
  using MemorySpace = Kokkos::HostSpace;
  const int B = 3, N = 7;
  Kokkos::View<real_t**, Kokkos::LayoutRight, MemorySpace> nodes("nodes", N, 9);
  rom::BatchMatrix<MemorySpace> xhat("xhat", B, r);
  Kokkos::View<int*, MemorySpace> flags("flags", B);
  fill_strain_node_rows(nodes, true);
  for (int b = 0; b < B; ++b)
    for (int q = 0; q < r; ++q) xhat(b, q) = real_t(xhat_host[q] * (1 + b));
  flags(1) = rom::flag_not_finite;
  rom::BatchVectors<MemorySpace> u("u", B, N, 3), block_u("block u", B, N, 3);
  rom::BatchJacobians<MemorySpace> dg("dg", B, N, 3, r), block_dg("block dg", B, N, 3, r);
  for (auto* view : {&u, &block_u}) Kokkos::deep_copy(*view, real_t(-7));  // what a stopped rollout keeps
  for (auto* view : {&dg, &block_dg}) Kokkos::deep_copy(*view, real_t(-7));
  const rom::GridStrainNodeKinematics<BendingManifold, MemorySpace> one{BendingManifold{}, nodes, xhat, u, dg, flags};
  Kokkos::parallel_for(Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(0, B * N), one);
  const long blocks = (B * N + nn::host_block_lanes - 1) / nn::host_block_lanes;
  Kokkos::parallel_for(Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(0, blocks),
                       rom::BlockGridStrainNodeKinematics<BendingManifold, MemorySpace>{
                           {BendingManifold{}, nodes, xhat, block_u, block_dg, flags}});
  expect_same(u, block_u, "node displacement");
  expect_same(dg, block_dg, "node dg/dxhat at the test point");
  EXPECT_EQ(block_u(1, 3, 0), real_t(-7)) << "a stopped rollout's node was written";

  using Samples = rom::SampleKinematics<BendingManifold, ExecutionSpace>;
  Kokkos::View<real_t**, Kokkos::LayoutRight, MemorySpace> Xv("X", S, 3);
  for (int i = 0; i < S; ++i)
    for (int d = 0; d < 3; ++d) Xv(i, d) = real_t(X[3 * i + d]);
  rom::BatchVectors<MemorySpace> x("x", B, S, 3), block_x("block x", B, S, 3);
  rom::BatchJacobians<MemorySpace> J("J", B, S, 3, r), block_J("block J", B, S, 3, r);
  Kokkos::parallel_for(Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(0, B * S),
                       Samples{BendingManifold{}, Xv, xhat, x, J, rom::TeamShape{}, rom::TeamScratch{}});
  const long sample_blocks = (B * S + nn::host_block_lanes - 1) / nn::host_block_lanes;
  Kokkos::parallel_for(Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(0, sample_blocks),
                       rom::BlockSampleKinematics<BendingManifold, ExecutionSpace>{Samples{
                           BendingManifold{}, Xv, xhat, block_x, block_J, rom::TeamShape{}, rom::TeamScratch{}}});
  expect_same(x, block_x, "sample position");
  expect_same(J, block_J, "sample dg/dxhat");
}

// The grid strain's nodes and the samples' kinematics in one team launch (TeamNodesAndSamples, small GPU batches)
// give what their own launches give: teams of up to 4 items (as many threads as the backend gives a team) over 3
// rollouts of 5 nodes and 6 samples, so that a team holds nodes and samples both and a rollout's items straddle teams.
// The analytic map runs the same one-thread arithmetic either way: equal to the bit.
TEST_F(GalerkinForce, NodesAndSamplesInOneLaunchMatchTheirOwnLaunches) {
  using ExecutionSpace = Kokkos::DefaultExecutionSpace;
  using MemorySpace = ExecutionSpace::memory_space;
  using Samples = rom::SampleKinematics<BendingManifold, ExecutionSpace>;
  const int B = 3, N = 5;
  Kokkos::View<real_t**, Kokkos::LayoutRight, MemorySpace> Xv("X", S, 3), nodes("nodes", N, 9);
  rom::BatchMatrix<MemorySpace> xhat("xhat", B, r);
  Kokkos::View<int*, MemorySpace> flags("flags", B);
  auto hX = Kokkos::create_mirror_view(Xv);
  auto hnodes = Kokkos::create_mirror_view(nodes);
  auto hxhat = Kokkos::create_mirror_view(xhat);
  for (int s = 0; s < S; ++s)
    for (int d = 0; d < 3; ++d) hX(s, d) = real_t(X[3 * s + d]);
  fill_strain_node_rows(hnodes, false);
  for (int b = 0; b < B; ++b)
    for (int q = 0; q < r; ++q) hxhat(b, q) = real_t(xhat_host[q] * (1 + b));
  Kokkos::deep_copy(Xv, hX);
  Kokkos::deep_copy(nodes, hnodes);
  Kokkos::deep_copy(xhat, hxhat);
  struct Outputs {
    rom::BatchVectors<MemorySpace> u{"u", B, N, 3}, x{"x", B, S, 3};
    rom::BatchJacobians<MemorySpace> dg{"dg", B, N, 3, r}, J{"J", B, S, 3, r};
  } own, merged;
  const rom::TeamScratch scratch = Samples::scratch_for(BendingManifold{});
  const Samples probe{BendingManifold{}, Xv, xhat, own.x, own.J, rom::TeamShape{}, scratch};
  const int most = Kokkos::TeamPolicy<ExecutionSpace>(1, 1).team_size_max(probe, Kokkos::ParallelForTag());
  const rom::TeamShape shape{std::min(4, most), 1, 1};
  Kokkos::parallel_for(Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(0, B * N),
                       rom::GridStrainNodeKinematics<BendingManifold, MemorySpace>{BendingManifold{}, nodes, xhat,
                                                                                   own.u, own.dg, flags});
  Kokkos::parallel_for(Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(0, B * S),
                       Samples{BendingManifold{}, Xv, xhat, own.x, own.J, shape, scratch});
  const rom::TeamNodesAndSamples<BendingManifold, ExecutionSpace> both{
      {BendingManifold{}, nodes, xhat, merged.u, merged.dg, shape, scratch, false},
      {BendingManifold{}, Xv, xhat, merged.x, merged.J, shape, scratch}};
  const int teams = (B * (N + S) + shape.threads - 1) / shape.threads;
  Kokkos::parallel_for(Kokkos::TeamPolicy<ExecutionSpace>(teams, shape.threads, shape.lanes)
                           .set_scratch_size(0, Kokkos::PerTeam(scratch.bytes(shape))),
                       both);
  expect_same(own.u, merged.u, "node displacement");
  expect_same(own.dg, merged.dg, "node dg/dxhat");
  expect_same(own.x, merged.x, "sample position");
  expect_same(own.J, merged.J, "sample dg/dxhat");
}

// On a lattice of equal masses: an interior node's centroid is the node, a node beyond the body's face has its
// centroid inside, the held layer's nodes are held, and F of a linear map comes out exact at an interior sample.
TEST(GridStrainStencils, CentroidsHeldNodesAndLinearFieldsOnALattice) {
  const GridGeometry<real_t> grid{{{real_t(-0.5), real_t(-0.5), real_t(-0.5)}}, real_t(0.1), real_t(10), {11, 11, 11}};
  std::vector<double> X, mass;
  for (int i = 0; i < 12; ++i)  // a cube [-0.275, 0.275]^3 of points half a cell apart
    for (int j = 0; j < 12; ++j)
      for (int k = 0; k < 12; ++k) {
        X.insert(X.end(), {-0.275 + 0.05 * i, -0.275 + 0.05 * j, -0.275 + 0.05 * k});
        mass.push_back(1);
      }
  rom::RolloutLoads loads{};
  loads.boundary.num_dirichlet = 1;  // the layer of nodes at z = -0.3 held
  const real_t held[6] = {-1, -1, real_t(-0.35), 1, 1, real_t(-0.25)};
  for (int d = 0; d < 6; ++d) loads.boundary.dirichlet_box[d] = held[d];
  loads.dirichlet_window[0] = 0;
  loads.dirichlet_window[1] = real_t(1e30);
  const std::vector<double> samples = {0.025, 0.025, 0.025, 0.225, 0.025, -0.225};
  const auto found = impl::grid_strain_nodes(grid, loads, 1.0, X, mass, samples, false, false);
  ASSERT_EQ(found.stencils.size(), 2u * 27);
  // Both stencils' x = 0.1 .. 0.3 nodes on the z = -0.1 layer are shared: 54 - 3 distinct nodes.
  EXPECT_EQ(found.nodes.size(), 51u * impl::grid_strain_node_values);
  std::vector<double> rows;  // each sample's 27 rows in stencil order
  for (const int i : found.stencils)
    rows.insert(rows.end(), found.nodes.begin() + i * impl::grid_strain_node_values,
                found.nodes.begin() + (i + 1) * impl::grid_strain_node_values);
  // Centroids are weighted means of coordinates within 0.3 of the node: rounding of a few eps of 1 in real_t.
  const double tolerance = 50 * std::numeric_limits<real_t>::epsilon();
  const auto node = [&](int s, int n) {
    return &rows[(std::size_t(s) * 27 + std::size_t(n)) * impl::grid_strain_node_values];
  };
  // Sample 0 at the lattice's centre: its stencil's nodes (-0.1 .. 0.1) see symmetric lattices.
  for (int n = 0; n < 27; ++n) {
    const double expected[3] = {-0.1 + 0.1 * (n / 9), -0.1 + 0.1 * ((n / 3) % 3), -0.1 + 0.1 * (n % 3)};
    for (int d = 0; d < 3; ++d) EXPECT_NEAR(node(0, n)[d], expected[d], tolerance) << "node " << n;
    for (int d = 0; d < 3; ++d) EXPECT_EQ(node(0, n)[3 + d], 1.0);
  }
  // Sample 1 near the +x face (x = 0.275): its stencil's x = 0.3 nodes lie beyond it, their centroids inside.
  EXPECT_LT(node(1, 18)[0], 0.275);
  EXPECT_GT(node(1, 18)[0], 0.2);
  // ... and near the bottom: its z = -0.3 nodes are held on every axis, the others free.
  for (int n = 0; n < 27; ++n)
    for (int d = 0; d < 3; ++d) EXPECT_EQ(node(1, n)[3 + d], n % 3 == 0 ? 0.0 : 1.0) << "node " << n;
  // With APIC and the node average: the strain's rows at the nodes themselves, the test functions' at the centroids
  // of the PIC rows above (the same sums).
  const auto averaged = impl::grid_strain_nodes(grid, loads, 1.0, X, mass, samples, true, true);
  ASSERT_EQ(averaged.nodes.size(), found.nodes.size());
  for (std::size_t i = 0; i < found.nodes.size() / impl::grid_strain_node_values; ++i) {
    const double* pic = &found.nodes[i * impl::grid_strain_node_values];
    const double* apic = &averaged.nodes[i * impl::grid_strain_node_values];
    for (int d = 0; d < 3; ++d) {
      EXPECT_EQ(pic[6 + d], pic[d]) << "node " << i;  // no node average: the test function where the node moves
      EXPECT_EQ(apic[6 + d], pic[d]) << "node " << i;
      EXPECT_NEAR(apic[d], std::round(apic[d] / 0.1) * 0.1, tolerance) << "node " << i;  // a grid node
    }
  }
  // A stretch along z, linear in X (the bending map at xhat = (0, 0, c)), at the centre: F = diag(1, 1, 1 + c).
  const double xhat[3] = {0, 0, 0.2};
  const Mat3<double> F = grid_strain(&samples[0], node(0, 0), grid, xhat);
  for (int a = 0; a < 3; ++a)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(F(a, c), a == c ? (a == 2 ? 1.2 : 1.0) : 0.0, tolerance);
}

}  // namespace
}  // namespace mpmrom::test
