// The manifold the reduced model moves on, as the ROM kernels see it: any type with
//   KOKKOS_FUNCTION int latent_dim() const;
//   KOKKOS_FUNCTION void kinematics(const real_t X[3], const real_t* xhat, const real_t* xhatdot,
//                                   nn::PointKinematics<real_t>& out, real_t* dgdxhat /* 3 x r or null */) const;
//   KOKKOS_FUNCTION void position_and_gradient(const real_t X[3], const real_t* xhat, real_t g[3],
//                                              real_t F[3][3]) const;
// MlpManifold adapts a trained network; tests plug in analytic maps. Parallelism contract: value types, every call
// within one thread.
#pragma once

#include "kernels/nn/mlp_kinematics.hpp"
#include "mpmrom_config.hpp"

namespace mpmrom::rom {

inline constexpr int max_latent_dim = 16;  // the r x r normal equations live in registers

template <int MaxWidth, class MemorySpace>
struct MlpManifold {
  nn::Mlp<real_t, MemorySpace> mlp;

  KOKKOS_INLINE_FUNCTION int latent_dim() const { return mlp.layout.latent_dim; }

  KOKKOS_INLINE_FUNCTION void kinematics(const real_t X[3], const real_t* xhat, const real_t* xhatdot,
                                         nn::PointKinematics<real_t>& out, real_t* dgdxhat) const {
    nn::SerialMlpKinematics<MaxWidth>(mlp, X, xhat, xhatdot, out, dgdxhat);
  }

  KOKKOS_INLINE_FUNCTION void position_and_gradient(const real_t X[3], const real_t* xhat, real_t g[3],
                                                    real_t F[3][3]) const {
    real_t unused[3 * max_latent_dim];
    nn::SerialMlpForwardJacobian<MaxWidth>(mlp, X, xhat, g, F, unused);
  }
};

}  // namespace mpmrom::rom
