// ELU activation and its first two derivatives (the paper's choice: continuously differentiable, so F = dg/dX and
// the velocity dg/dxhat * xhatdot are continuous; the second derivative is needed to train on those Jacobians).
#pragma once

#include "kernels/compat/kokkos_compat.hpp"

namespace mpmrom::nn {

// elu(a) = a for a > 0, exp(a) - 1 otherwise (alpha = 1).
template <class T>
KOKKOS_INLINE_FUNCTION T elu(T a) {
  return a > T(0) ? a : T(math::expm1(a));
}

// d elu / da: 1 for a > 0, exp(a) otherwise; always positive.
template <class T>
KOKKOS_INLINE_FUNCTION T elu_derivative(T a) {
  return a > T(0) ? T(1) : T(math::exp(a));
}

// d^2 elu / da^2: 0 for a > 0, exp(a) otherwise (the jump at 0 is where ELU stops being twice differentiable).
template <class T>
KOKKOS_INLINE_FUNCTION T elu_second_derivative(T a) {
  return a > T(0) ? T(0) : T(math::exp(a));
}

// elu(a) and elu'(a) from one exponential (the forward pass needs both).
template <class T>
KOKKOS_INLINE_FUNCTION void elu_and_derivative(T a, T& value, T& derivative) {
  if (a > T(0)) {
    value = a;
    derivative = T(1);
  } else {
    derivative = T(math::exp(a));
    value = derivative - T(1);  // exp(a) - 1 rounds to within eps of expm1(a): absolute, not relative, accuracy
  }
}

}  // namespace mpmrom::nn
