// The Galerkin step's per-sample terms (RomMethod::Galerkin, docs/rom.md "Galerkin step"): the reduced equations of
// motion on the manifold, d/dt (M xhatdot) = f, with the energy E(xhat) = sum_p V_p psi(F_p(xhat)) of the manifold's
// own deformation gradients and the external loads, assembled by cubature over the samples without a grid:
//   f = sum_s w_s m_s q_s,   q_s = -(1 / rho0) P(F_s) : dF_s/dxhat + J_s^T (b(X_s, t) + gravity),
//   M = sum_s w_s m_s J_s^T J_s,
// with P the first Piola-Kirchhoff stress and w_s the cubature weight (1: every point). The projection
// (projection.hpp) then solves M(xhat_n+1) xhatdot_n+1 = sum_s w_s m_s J_s(xhat_n+1)^T v_s + dt f,
// v_s = J_s(xhat_n) xhatdot_n: the momentum carried onto the new tangent space plus the impulse. Parallelism: one
// thread per (rollout, sample); the network runs r + 1 times at the sample (dF/dxhat_k is the kinematics' Fdot along
// the unit rate e_k).
#pragma once

#include "mpm/constitutive.hpp"
#include "rom/kernels/loads.hpp"
#include "rom/kernels/manifold.hpp"
#include "rom/kernels/projection.hpp"
#include "rom/kernels/sources.hpp"

namespace mpmrom::rom {

template <class Manifold, class MemorySpace>
struct GalerkinSampleTerms {
  Manifold manifold;
  Kokkos::View<const real_t**, Kokkos::LayoutRight, MemorySpace> X;  // (samples, 3)
  BatchMatrix<MemorySpace> xhat, xhatdot;
  Kokkos::View<const RolloutLoads*, MemorySpace> loads;
  ElasticMaterial<real_t> material;
  real_t density, time;
  BatchVectors<MemorySpace> sample_x, sample_v;  // out: (rollouts, samples, 3)
  BatchJacobians<MemorySpace> sample_J;          // out: (rollouts, samples, 3, r)
  BatchMatrix<MemorySpace> sample_force;         // out: (rollouts, samples * r): q_s, per unit mass
  Kokkos::View<int*, MemorySpace> flags;

  KOKKOS_INLINE_FUNCTION void operator()(const long e, real_t& max_speed) const {
    const int num_samples = int(X.extent(0)), r = int(xhat.extent(1));
    const int b = int(e / num_samples), s = int(e % num_samples);
    if (flags(b) & fatal_flags) return;
    const real_t Xs[3] = {X(s, 0), X(s, 1), X(s, 2)};
    nn::PointKinematics<real_t> kin;
    manifold.kinematics(Xs, &xhat(b, 0), &xhatdot(b, 0), kin, &sample_J(b, s, 0, 0));
    Mat3<real_t> F;
    real_t J;
    if (!deformation_gradient(kin, flags, b, F, J)) return;
    const Mat3<real_t> P = first_piola(material, F);
    Vec3<real_t> body = loads(b).force_per_unit_mass({{Xs[0], Xs[1], Xs[2]}}, time);
    for (int d = 0; d < 3; ++d) body[d] += loads(b).gravity[d];
    real_t unit[max_latent_dim] = {};
    for (int k = 0; k < r; ++k) {
      unit[k] = real_t(1);
      nn::PointKinematics<real_t> along;
      manifold.kinematics(Xs, &xhat(b, 0), unit, along, nullptr);
      unit[k] = real_t(0);
      real_t power = 0;  // P : dF/dxhat_k
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) power += P(i, j) * along.Fdot[i][j];
      real_t q = -power / density;
      for (int d = 0; d < 3; ++d) q += sample_J(b, s, d, k) * body[d];
      sample_force(b, s * r + k) = q;
    }
    for (int d = 0; d < 3; ++d) {
      sample_x(b, s, d) = kin.g[d];
      sample_v(b, s, d) = kin.v[d];
    }
    const real_t speed = norm(Vec3<real_t>{{kin.v[0], kin.v[1], kin.v[2]}});
    if (speed > max_speed) max_speed = speed;
  }
};

}  // namespace mpmrom::rom
