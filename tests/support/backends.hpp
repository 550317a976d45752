// The Kokkos execution spaces this build enables. A typed test over EnabledBackends is written once and runs on every
// backend (Serial, OpenMP, Cuda), in the style of Cabana's per-backend tests.
#pragma once

#include <gtest/gtest.h>

#include <Kokkos_Core.hpp>

#include <random>
#include <vector>

#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom::test {

template <class... Ts>
struct TypeList {};

template <class List, bool enabled, class T>
struct AppendIf;
template <class... Ts, class T>
struct AppendIf<TypeList<Ts...>, true, T> {
  using type = TypeList<Ts..., T>;
};
template <class... Ts, class T>
struct AppendIf<TypeList<Ts...>, false, T> {
  using type = TypeList<Ts...>;
};

#ifdef KOKKOS_ENABLE_SERIAL
using WithSerial = AppendIf<TypeList<>, true, Kokkos::Serial>::type;
#else
using WithSerial = TypeList<>;
#endif
#ifdef KOKKOS_ENABLE_OPENMP
using WithOpenMP = AppendIf<WithSerial, true, Kokkos::OpenMP>::type;
#else
using WithOpenMP = WithSerial;
#endif
#ifdef KOKKOS_ENABLE_CUDA
using WithCuda = AppendIf<WithOpenMP, true, Kokkos::Cuda>::type;
#else
using WithCuda = WithOpenMP;
#endif

template <class List>
struct ToGTestTypes;
template <class... Ts>
struct ToGTestTypes<TypeList<Ts...>> {
  using type = ::testing::Types<Ts...>;
};

using EnabledBackends = ToGTestTypes<WithCuda>::type;

// Prints the backend's name in test names, e.g. Mat3/OpenMP.
struct BackendName {
  template <class ExecutionSpace>
  static std::string GetName(int) {
    return ExecutionSpace::name();
  }
};

// Machine epsilon of the configured precision: tolerances in the tests are written as multiples of it.
constexpr double eps = std::numeric_limits<real_t>::epsilon();

// Uniform random numbers in [lo, hi) from a fixed seed, copied into a View of the execution space's memory.
template <class ExecutionSpace>
Kokkos::View<real_t*, typename ExecutionSpace::memory_space> random_view(const char* label, std::size_t n, double lo,
                                                                         double hi, unsigned seed) {
  Kokkos::View<real_t*, typename ExecutionSpace::memory_space> view(std::string(label), n);
  auto host = Kokkos::create_mirror_view(view);
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> dist(lo, hi);
  for (std::size_t i = 0; i < n; ++i) host(i) = static_cast<real_t>(dist(rng));
  Kokkos::deep_copy(view, host);
  return view;
}

}  // namespace mpmrom::test
