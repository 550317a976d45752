// The compatibility layer gives the same answers on every backend and Kokkos version.
#include <cmath>
#include <limits>

#include "backends.hpp"
#include "core/kokkos_compat.hpp"

namespace mpmrom::test {
namespace {

template <class ExecutionSpace>
void check_math_matches_std() {
  const std::size_t n = 1000;
  auto x = random_view<ExecutionSpace>("x", n, 0.1, 4.0, 1);
  Kokkos::View<real_t* [6], typename ExecutionSpace::memory_space> out("out", n);
  Kokkos::parallel_for(
      "mpmrom::test::compat_math", Kokkos::RangePolicy<ExecutionSpace>(0, n), KOKKOS_LAMBDA(const int i) {
        const real_t v = x(i);
        out(i, 0) = math::sqrt(v);
        out(i, 1) = math::exp(-v);
        out(i, 2) = math::log(v);
        out(i, 3) = math::cbrt(v);
        out(i, 4) = math::max(v, real_t(2)) - math::min(v, real_t(2));
        real_t a = v, b = -v;
        math::swap(a, b);
        out(i, 5) = a;
      });
  auto h_x = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), x);
  auto h_out = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), out);
  // Device libraries round differently from the host's libm by at most a few ulps.
  const double tol = 8 * eps;
  for (std::size_t i = 0; i < n; ++i) {
    const double v = h_x(i);
    EXPECT_NEAR(h_out(i, 0), std::sqrt(v), tol * std::sqrt(v));
    EXPECT_NEAR(h_out(i, 1), std::exp(-v), tol * std::exp(-v));
    EXPECT_NEAR(h_out(i, 2), std::log(v), tol * (1 + std::fabs(std::log(v))));
    EXPECT_NEAR(h_out(i, 3), std::cbrt(v), tol * std::cbrt(v));
    EXPECT_NEAR(h_out(i, 4), std::fabs(v - 2), tol * 4);
    EXPECT_EQ(h_out(i, 5), -h_x(i));
  }
}

template <class ExecutionSpace>
class Compat : public ::testing::Test {};
TYPED_TEST_SUITE(Compat, EnabledBackends, BackendName);

TYPED_TEST(Compat, MathMatchesStd) { check_math_matches_std<TypeParam>(); }

TEST(CompatHost, EpsilonAndVersion) {
  EXPECT_EQ(math::epsilon<float>(), std::numeric_limits<float>::epsilon());
  EXPECT_EQ(math::epsilon<double>(), std::numeric_limits<double>::epsilon());
  const std::string expected = std::to_string(KOKKOS_VERSION / 10000) + "." +
                               std::to_string(KOKKOS_VERSION / 100 % 100) + "." + std::to_string(KOKKOS_VERSION % 100);
  EXPECT_EQ(compat::kokkos_version_string(), expected);
  EXPECT_GE(compat::concurrency(Kokkos::DefaultHostExecutionSpace()), 1);
}

}  // namespace
}  // namespace mpmrom::test
