// Adam (Kingma and Ba, 2015) on a range of a flat parameter array.
#pragma once

#include <Kokkos_Core.hpp>

#include <cmath>

#include "core/kokkos_compat.hpp"

namespace mpmrom::nn {

struct AdamSettings {
  double beta1 = 0.9;
  double beta2 = 0.999;
  double epsilon = 1e-8;
};

// One Adam step (step counts from 1) with learning rate lr on params[begin, end): first and second moments m, v are
// updated in place and bias-corrected. Parallelism contract: one thread per parameter; no reduction.
template <class ExecutionSpace, class T, class MemorySpace>
void adam_step(const ExecutionSpace& space, const Kokkos::View<T*, MemorySpace>& params,
               const Kokkos::View<const T*, MemorySpace>& grad, const Kokkos::View<T*, MemorySpace>& m,
               const Kokkos::View<T*, MemorySpace>& v, const int begin, const int end, const double lr, const long step,
               const AdamSettings settings = {}) {
  const T beta1 = T(settings.beta1), beta2 = T(settings.beta2), epsilon = T(settings.epsilon);
  // bias corrections in double: beta2^step is 1 - O(step * 1e-3), which float would round badly
  const T step_size = T(lr / (1 - std::pow(settings.beta1, double(step))));
  const T inv_sqrt_correction2 = T(1 / std::sqrt(1 - std::pow(settings.beta2, double(step))));
  Kokkos::parallel_for(
      "mpmrom::nn::adam", Kokkos::RangePolicy<ExecutionSpace>(space, begin, end), KOKKOS_LAMBDA(const int p) {
        const T g = grad(p);
        const T mp = beta1 * m(p) + (1 - beta1) * g;
        const T vp = beta2 * v(p) + (1 - beta2) * g * g;
        m(p) = mp;
        v(p) = vp;
        params(p) -= step_size * mp / (math::sqrt(vp) * inv_sqrt_correction2 + epsilon);
      });
}

}  // namespace mpmrom::nn
