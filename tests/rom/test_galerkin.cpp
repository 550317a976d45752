// The Galerkin step's reduced force (rom/kernels/galerkin.hpp): minus the gradient of the samples' elastic energy,
// checked against central differences of that energy, plus the loads' generalised force.
#include <gtest/gtest.h>

#include <Kokkos_Core.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include "rom/kernels/galerkin.hpp"

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

TEST(RomGalerkin, ReducedForceIsMinusTheEnergyGradientPlusTheLoads) {
  using ExecutionSpace = Kokkos::DefaultExecutionSpace;
  using MemorySpace = ExecutionSpace::memory_space;
  constexpr int S = 6, r = 3;
  const double density = 100, xhat_host[r] = {0.4, -0.3, 0.2};
  const std::vector<double> X = {0.1,  0,    0.05, -0.1,  0.05, 0.2, 0, -0.1, 0.35,
                                 0.05, 0.05, 0.4,  -0.05, 0,    0.1, 0, 0,    0.3};
  std::vector<double> mass(S), volume(S);
  for (int s = 0; s < S; ++s) mass[s] = 0.01 * (1 + s), volume[s] = mass[s] / density;
  const auto material = elastic_material(ElasticModel::FixedCorotated, real_t(12500), real_t(0.3));
  const ElasticMaterial<double> material_double{material.model, double(material.mu), double(material.lambda)};

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
  }
  real_t fastest = 0;
  Kokkos::parallel_reduce(
      Kokkos::RangePolicy<ExecutionSpace, Kokkos::IndexType<long>>(0, S),
      rom::GalerkinSampleTerms<BendingManifold, MemorySpace>{BendingManifold{}, Xv, xhat, xhatdot, loads, material,
                                                             real_t(density), real_t(0.5), x, v, J, force, flags},
      Kokkos::Max<real_t>(fastest));
  const auto q = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), force);
  ASSERT_EQ(Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), flags)(0), 0);

  // Central differences in double: truncation h^2 |E'''| / 6 and rounding eps_d |E| / h, both below 1e-9 of the
  // force at h = 1e-5 on this O(1) strain; the kernel's own rounding in real_t is a few hundred eps of the terms.
  const double h = 1e-5, eps = std::numeric_limits<real_t>::epsilon();
  for (int k = 0; k < r; ++k) {
    double plus[r], minus[r];
    for (int q = 0; q < r; ++q) plus[q] = minus[q] = xhat_host[q];
    plus[k] += h;
    minus[k] -= h;
    double expected =
        -(elastic_energy(X, volume, plus, material_double) - elastic_energy(X, volume, minus, material_double)) /
        (2 * h);
    double computed = 0, scale = std::fabs(expected);
    for (int s = 0; s < S; ++s) {
      const double Z = X[3 * s + 2], column[3] = {Z * Z, Z * Z, Z};
      const double body[3] = {Z >= 0.25 ? 1.0 : 0.0, Z >= 0.25 ? 2.0 : 0.0, (Z >= 0.25 ? 3.0 : 0.0) - 9.81};
      expected += mass[s] * column[k] * body[k];
      computed += mass[s] * double(q(0, s * r + k));
      scale += mass[s] * std::fabs(column[k] * body[k]);
    }
    EXPECT_NEAR(computed, expected, (1e-9 + 300 * eps) * scale) << "xhat component " << k;
  }
}

}  // namespace
}  // namespace mpmrom::test
