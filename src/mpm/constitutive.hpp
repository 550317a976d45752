// Hyperelastic constitutive models (compressible neo-Hookean; fixed-corotated, Stomakhin et al. 2012): energy density,
// first Piola-Kirchhoff and Kirchhoff stress of a deformation gradient F. Parallelism contract: each routine runs
// entirely within the calling thread (one particle per call; no heap, no recursion, no virtual dispatch).
#pragma once

#include "core/math/mat3.hpp"
#include "core/math/polar3.hpp"
#include "core/math/unroll.hpp"

namespace mpmrom {

enum class ElasticModel : int { NeoHookean = 0, FixedCorotated = 1 };

template <class T>
struct ElasticMaterial {
  ElasticModel model;
  T mu;      // shear modulus (Lame's second parameter), Pa
  T lambda;  // Lame's first parameter, Pa
};

// Lame parameters from Young's modulus E and Poisson's ratio nu (-1 < nu < 1/2):
// mu = E / (2 (1 + nu)), lambda = E nu / ((1 + nu) (1 - 2 nu)).
template <class T>
KOKKOS_INLINE_FUNCTION ElasticMaterial<T> elastic_material(ElasticModel model, T youngs_modulus, T poisson_ratio) {
  ElasticMaterial<T> m;
  m.model = model;
  m.mu = youngs_modulus / (T(2) * (T(1) + poisson_ratio));
  m.lambda = youngs_modulus * poisson_ratio / ((T(1) + poisson_ratio) * (T(1) - T(2) * poisson_ratio));
  return m;
}

// P-wave speed sqrt((lambda + 2 mu) / density), the fastest elastic wave: the CFL limit is dt <= C dx / speed.
template <class T>
KOKKOS_INLINE_FUNCTION T stable_time_step_wave_speed(const ElasticMaterial<T>& m, T density) {
  return math::sqrt((m.lambda + T(2) * m.mu) / density);
}

// Neo-Hookean is undefined for J = det F <= 0 (ln J). Rather than return NaN, it is evaluated with J clamped to
// [neo_hookean_min_jacobian, inf) wherever J enters through ln J or 1/J: energy and stresses stay finite for every
// finite F (also inverted or singular), are continuous in F, and for J below the clamp the stress still pushes towards
// larger J (P : cof F < 0 unless cof F ~ 0, i.e. rank F <= 1), but P is no longer the derivative of Psi there. The
// solver must detect inversion (J <= 0) itself. 1e-6 is far past any physical state (the stress there is ~1e6 mu),
// and keeps lambda |ln J| / J at ~1.4e19 for lambda = 1e12 Pa, far inside float's range.
template <class T>
KOKKOS_INLINE_FUNCTION constexpr T neo_hookean_min_jacobian() {
  return T(1e-6);
}

namespace detail {

// A model value outside the enum (a bad cast) aborts the kernel: there is no meaningful stress to return.
KOKKOS_INLINE_FUNCTION void invalid_elastic_model() {
  Kokkos::abort("mpmrom: ElasticMaterial::model is not a valid ElasticModel");
}

// Psi = mu/2 (tr(F^T F) - 3) - mu ln J + lambda/2 (ln J)^2.
template <class T>
KOKKOS_INLINE_FUNCTION T neo_hookean_energy(const ElasticMaterial<T>& m, const Mat3<T>& F) {
  const T log_j = math::log(math::max(determinant(F), neo_hookean_min_jacobian<T>()));
  return T(0.5) * m.mu * (ddot(F, F) - T(3)) - m.mu * log_j + T(0.5) * m.lambda * log_j * log_j;
}

// P = mu F + (lambda ln J - mu) F^{-T}, with F^{-T} = cof(F) / J.
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> neo_hookean_first_piola(const ElasticMaterial<T>& m, const Mat3<T>& F) {
  const T j = math::max(determinant(F), neo_hookean_min_jacobian<T>());
  return m.mu * F + ((m.lambda * math::log(j) - m.mu) / j) * cofactor(F);
}

// tau = P F^T = mu F F^T + (lambda ln J - mu) I, since cof(F) F^T = det(F) I (the ratio det F / J is 1 unless clamped).
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> neo_hookean_kirchhoff(const ElasticMaterial<T>& m, const Mat3<T>& F) {
  const T det = determinant(F);
  const T j = math::max(det, neo_hookean_min_jacobian<T>());
  const T diagonal = (m.lambda * math::log(j) - m.mu) * (det / j);
  // mu F F^T, each off-diagonal entry computed once and mirrored: exactly symmetric whatever FMA contraction does
  Mat3<T> tau;
  for (int a = 0; a < 3; ++a)
    for (int b = a; b < 3; ++b) {
      const T s = m.mu * (F(a, 0) * F(b, 0) + F(a, 1) * F(b, 1) + F(a, 2) * F(b, 2));
      tau(a, b) = s;
      tau(b, a) = s;
    }
  for (int i = 0; i < 3; ++i) tau(i, i) += diagonal;
  return tau;
}

// The fixed corotated energy density and Kirchhoff stress from F, its determinant j and its polar rotation R:
// Psi = mu |F - R|_F^2 + lambda/2 (j - 1)^2 (= mu sum_i (sigma_i - 1)^2 + ..., R = U V^T) and
// tau = 2 mu (F - R) F^T + lambda (j - 1) j I, whose off-diagonal entries are averaged with their mirror (R F^T = R S
// R^T is symmetric up to rounding) so that tau is exactly symmetric. One home for the scalar and the lanes' arithmetic.
template <class T>
KOKKOS_INLINE_FUNCTION void fixed_corotated_from_rotation(const ElasticMaterial<T>& m, const T (&F)[3][3],
                                                          const T (&R)[3][3], T j, T (&tau)[3][3], T* psi) {
  T D[3][3];
  T stretch = T(0);
  MPMROM_UNROLL
  for (int a = 0; a < 3; ++a) {
    MPMROM_UNROLL
    for (int b = 0; b < 3; ++b) {
      D[a][b] = F[a][b] - R[a][b];
      stretch += D[a][b] * D[a][b];
    }
  }
  if (psi != nullptr) *psi = m.mu * stretch + T(0.5) * m.lambda * (j - T(1)) * (j - T(1));
  const T volumetric = m.lambda * (j - T(1)) * j;
  MPMROM_UNROLL
  for (int a = 0; a < 3; ++a) {
    MPMROM_UNROLL
    for (int b = 0; b < 3; ++b) {
      if (b < a) continue;  // the lower triangle mirrors the upper
      const T ab = D[a][0] * F[b][0] + D[a][1] * F[b][1] + D[a][2] * F[b][2];
      const T ba = D[b][0] * F[a][0] + D[b][1] * F[a][1] + D[b][2] * F[a][2];
      const T s = m.mu * (ab + ba);
      tau[a][b] = s;
      tau[b][a] = s;
    }
  }
  MPMROM_UNROLL
  for (int i = 0; i < 3; ++i) tau[i][i] += volumetric;
}

// Psi = mu |F - R|^2 + lambda/2 (J - 1)^2 = mu sum_i (sigma_i - 1)^2 + lambda/2 (J - 1)^2, R = U V^T.
template <class T>
KOKKOS_INLINE_FUNCTION T fixed_corotated_energy(const ElasticMaterial<T>& m, const Mat3<T>& F) {
  const Mat3<T> R = polar_rotation(F);
  const T jm1 = determinant(F) - T(1);
  return m.mu * ddot(F - R, F - R) + T(0.5) * m.lambda * jm1 * jm1;
}

// P = 2 mu (F - R) + lambda (J - 1) cof(F); cof(F) = J F^{-T} is defined for singular F too.
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> fixed_corotated_first_piola(const ElasticMaterial<T>& m, const Mat3<T>& F) {
  const Mat3<T> R = polar_rotation(F);
  return (T(2) * m.mu) * (F - R) + (m.lambda * (determinant(F) - T(1))) * cofactor(F);
}

// tau = P F^T = 2 mu (F - R) F^T + lambda (J - 1) J I (fixed_corotated_from_rotation). With psi, also the energy
// density from the same R.
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> fixed_corotated_kirchhoff(const ElasticMaterial<T>& m, const Mat3<T>& F,
                                                         T* psi = nullptr) {
  const Mat3<T> R = polar_rotation(F);
  Mat3<T> tau;
  fixed_corotated_from_rotation(m, F.m, R.m, determinant(F), tau.m, psi);
  return tau;
}

}  // namespace detail

// Strain energy density Psi(F) per unit reference volume.
template <class T>
KOKKOS_INLINE_FUNCTION T energy_density(const ElasticMaterial<T>& m, const Mat3<T>& F) {
  switch (m.model) {
    case ElasticModel::NeoHookean: return detail::neo_hookean_energy(m, F);
    case ElasticModel::FixedCorotated: return detail::fixed_corotated_energy(m, F);
  }
  detail::invalid_elastic_model();
  return T(0);  // not reached where Kokkos::abort is noreturn
}

// First Piola-Kirchhoff stress P = dPsi/dF.
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> first_piola(const ElasticMaterial<T>& m, const Mat3<T>& F) {
  switch (m.model) {
    case ElasticModel::NeoHookean: return detail::neo_hookean_first_piola(m, F);
    case ElasticModel::FixedCorotated: return detail::fixed_corotated_first_piola(m, F);
  }
  detail::invalid_elastic_model();
  return Mat3<T>::zero();  // not reached where Kokkos::abort is noreturn
}

// Kirchhoff stress tau = P F^T = J sigma (sigma: Cauchy stress), symmetric. MPM's grid force is
// f_i = -sum_p V0_p tau_p grad w_ip. With psi, also the energy density Psi(F) (sharing the fixed corotated model's
// polar rotation, the costly part of both).
template <class T>
KOKKOS_INLINE_FUNCTION Mat3<T> kirchhoff_stress(const ElasticMaterial<T>& m, const Mat3<T>& F, T* psi = nullptr) {
  switch (m.model) {
    case ElasticModel::NeoHookean:
      if (psi != nullptr) *psi = detail::neo_hookean_energy(m, F);
      return detail::neo_hookean_kirchhoff(m, F);
    case ElasticModel::FixedCorotated: return detail::fixed_corotated_kirchhoff(m, F, psi);
  }
  detail::invalid_elastic_model();
  return Mat3<T>::zero();  // not reached where Kokkos::abort is noreturn
}

}  // namespace mpmrom
