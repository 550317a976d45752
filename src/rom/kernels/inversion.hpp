// Algorithm 2's inverse map: the reference position X with g(X; xhat) = x for a given current position x, by Newton's
// method on the 3 x 3 system (F = dg/dX), with step halving when a step does not reduce the residual.
// Parallelism contract: one thread per inversion.
#pragma once

#include "core/math/mat3.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom::rom {

struct NewtonSettings {
  real_t tolerance = 0;  // converged when |g(X) - x| <= tolerance (length units)
  int max_iterations = 20;
};

// On entry X holds the initial guess; on return the last iterate. True when converged. Fails (false) when the
// iteration limit is reached, F is singular (det F <= 0: the map is not locally invertible there) or the residual is
// not finite.
template <class Manifold>
KOKKOS_INLINE_FUNCTION bool SerialInvertMap(const Manifold& manifold, const Vec3<real_t>& x, const real_t* xhat,
                                            const NewtonSettings& settings, Vec3<real_t>& X) {
  real_t g[3], F[3][3];
  manifold.position_and_gradient(&X[0], xhat, g, F);
  Vec3<real_t> residual{{g[0] - x[0], g[1] - x[1], g[2] - x[2]}};
  real_t norm_residual = norm(residual);
  for (int iteration = 0; iteration < settings.max_iterations; ++iteration) {
    if (!(norm_residual == norm_residual) || norm_residual > real_t(1e30)) return false;
    if (norm_residual <= settings.tolerance) return true;
    Mat3<real_t> gradient;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) gradient(i, j) = F[i][j];
    if (!(determinant(gradient) > real_t(0))) return false;
    const Vec3<real_t> step = inverse(gradient) * residual;
    real_t length = 1;
    bool reduced = false;
    for (int halving = 0; halving < 8 && !reduced; ++halving, length *= real_t(0.5)) {
      const Vec3<real_t> trial{{X[0] - length * step[0], X[1] - length * step[1], X[2] - length * step[2]}};
      real_t g_trial[3], F_trial[3][3];
      manifold.position_and_gradient(&trial[0], xhat, g_trial, F_trial);
      const Vec3<real_t> r_trial{{g_trial[0] - x[0], g_trial[1] - x[1], g_trial[2] - x[2]}};
      const real_t n_trial = norm(r_trial);
      if (n_trial < norm_residual) {
        X = trial;
        residual = r_trial;
        norm_residual = n_trial;
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) F[i][j] = F_trial[i][j];
        reduced = true;
      }
    }
    if (!reduced) return norm_residual <= settings.tolerance;
  }
  return norm_residual <= settings.tolerance;
}

}  // namespace mpmrom::rom
