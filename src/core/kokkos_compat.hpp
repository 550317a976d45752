// Every difference between Kokkos 3.4.1 (Debian's Trilinos) and Kokkos 4.x that mpmrom meets, in one place.
// Each switch says when it can go: once the oldest supported Kokkos is at least the version named.
#pragma once

#include <Kokkos_Core.hpp>

#include <cstdio>
#include <string>

#define MPMROM_KOKKOS_AT_LEAST(major, minor, patch) (KOKKOS_VERSION >= ((major)*10000 + (minor)*100 + (patch)))

namespace mpmrom {
namespace math {

// Math functions moved from Kokkos::Experimental to Kokkos in 3.7; the Experimental aliases were removed in 4.3.
// Remove when the minimum is 3.7.
#if MPMROM_KOKKOS_AT_LEAST(3, 7, 0)
namespace kokkos_math = ::Kokkos;
#else
namespace kokkos_math = ::Kokkos::Experimental;
#endif

using kokkos_math::acos;
using kokkos_math::atan2;
using kokkos_math::cbrt;
using kokkos_math::cos;
using kokkos_math::exp;
using kokkos_math::fabs;
using kokkos_math::floor;
using kokkos_math::fmax;
using kokkos_math::fmin;
using kokkos_math::isfinite;
using kokkos_math::isnan;
using kokkos_math::log;
using kokkos_math::log1p;
using kokkos_math::pow;
using kokkos_math::sin;
using kokkos_math::sqrt;
using kokkos_math::tanh;

// Kokkos 3.4 has no Kokkos::min/max/abs usable in kernels for floating point; these work everywhere.
template <class T>
KOKKOS_INLINE_FUNCTION constexpr T min(T a, T b) {
  return b < a ? b : a;
}
template <class T>
KOKKOS_INLINE_FUNCTION constexpr T max(T a, T b) {
  return a < b ? b : a;
}
template <class T>
KOKKOS_INLINE_FUNCTION constexpr T clamp(T x, T lo, T hi) {
  return x < lo ? lo : (hi < x ? hi : x);
}

// Kokkos::kokkos_swap arrived in 4.3; std::swap is not a device function. Remove when the minimum is 4.3.
template <class T>
KOKKOS_INLINE_FUNCTION void swap(T& a, T& b) {
  T tmp = a;
  a = b;
  b = tmp;
}

// Machine epsilon: 3.4 has Kokkos::Experimental::epsilon<T>::value, 4.x still has it (next to epsilon_v).
// Remove the wrapper when Kokkos moves the traits out of Experimental.
template <class T>
KOKKOS_INLINE_FUNCTION constexpr T epsilon() {
  return Kokkos::Experimental::epsilon<T>::value;
}

}  // namespace math

namespace compat {

// Number of threads (or concurrent lanes) of an execution space instance; concurrency() became non-static in 4.0.
template <class ExecutionSpace>
int concurrency(const ExecutionSpace& space = ExecutionSpace()) {
  return space.concurrency();
}

// Initialise Kokkos with a thread count and a device id (-1: Kokkos' defaults). InitArguments (3.x) became
// InitializationSettings (3.7) and InitArguments was removed in 4.0. Remove the 3.x branch when the minimum is 3.7.
inline void initialize(int num_threads, int device_id) {
#if MPMROM_KOKKOS_AT_LEAST(3, 7, 0)
  Kokkos::InitializationSettings settings;
  if (num_threads > 0) settings.set_num_threads(num_threads);
  if (device_id >= 0) settings.set_device_id(device_id);
  Kokkos::initialize(settings);
#else
  Kokkos::InitArguments args;
  if (num_threads > 0) args.num_threads = num_threads;
  if (device_id >= 0) args.device_id = device_id;
  Kokkos::initialize(args);
#endif
}

// Version of the Kokkos the code was compiled against, as "major.minor.patch".
inline std::string kokkos_version_string() {
  return std::to_string(KOKKOS_VERSION / 10000) + "." + std::to_string(KOKKOS_VERSION / 100 % 100) + "." +
         std::to_string(KOKKOS_VERSION % 100);
}

}  // namespace compat
}  // namespace mpmrom

// printf inside kernels: Kokkos::printf since 4.2; plain printf before (fine on host and CUDA). Remove with 4.2.
#if MPMROM_KOKKOS_AT_LEAST(4, 2, 0)
#define MPMROM_KERNEL_PRINTF(...) Kokkos::printf(__VA_ARGS__)
#else
#define MPMROM_KERNEL_PRINTF(...) printf(__VA_ARGS__)
#endif

// The join() of a reduction functor took volatile arguments before 3.7 (required in 3.4; deprecated in 3.7, ignored
// by 4.x). Write `void join(MPMROM_REDUCTION_VOLATILE value_type dst, const MPMROM_REDUCTION_VOLATILE value_type src)`.
// Remove when the minimum is 3.7.
#if MPMROM_KOKKOS_AT_LEAST(3, 7, 0)
#define MPMROM_REDUCTION_VOLATILE
#else
#define MPMROM_REDUCTION_VOLATILE volatile
#endif
