// ELU activation and its derivative (the paper's choice: continuously differentiable, so F = dg/dX and the velocity
// dg/dxhat * xhatdot are continuous). Its second derivative, needed to train on those Jacobians and for the
// second-order kinematics, is elu'' = elu' = exp(a) below zero and 0 above: callers take it from elu' (no exp).
#pragma once

#include "core/kokkos_compat.hpp"

namespace mpmrom::nn {

// elu(a) = a for a > 0, exp(a) - 1 otherwise (alpha = 1), rounded as elu_and_derivative rounds it (which training
// and the Jacobian kernels use), so that a forward pass gives the same g with or without its Jacobians; exp is
// also about half the cost of expm1, which took over half of a forward pass's time on a CPU.
template <class T>
KOKKOS_INLINE_FUNCTION T elu(T a) {
  return a > T(0) ? a : T(math::exp(a)) - T(1);
}

// d elu / da: 1 for a > 0, exp(a) otherwise; always positive.
template <class T>
KOKKOS_INLINE_FUNCTION T elu_derivative(T a) {
  return a > T(0) ? T(1) : T(math::exp(a));
}

// elu(a) and elu'(a) from one exponential (the forward pass needs both).
template <class T>
KOKKOS_INLINE_FUNCTION void elu_and_derivative(T a, T& value, T& derivative) {
  if (a > T(0)) {
    value = a;
    derivative = T(1);
  } else {
    derivative = T(math::exp(a));
    value = derivative - T(1);  // within eps of expm1(a): absolute, not relative, accuracy, all an activation needs
  }
}

}  // namespace mpmrom::nn
