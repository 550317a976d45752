// 3x3 algebra on device against identities that hold exactly in exact arithmetic.
#include <cmath>

#include "backends.hpp"
#include "core/math/mat3.hpp"

namespace mpmrom::test {
namespace {

using M = Mat3<real_t>;

// Residuals of identities, one row per random matrix pair: |A A^-1 - I|, |det(AB) - det A det B|,
// |cof(A) - det(A) A^-T|, |A B^T - multiply_transposed(A, B)|, |(A^T)^T - A|, |A (B x) - (A B) x|.
template <class ExecutionSpace>
void check_identities() {
  const int n = 2000;
  auto entries = random_view<ExecutionSpace>("entries", 21 * n, -0.3, 0.3, 7);
  Kokkos::View<double* [7], typename ExecutionSpace::memory_space> residual("residual", n);
  Kokkos::parallel_for(
      "mpmrom::test::mat3_identities", Kokkos::RangePolicy<ExecutionSpace>(0, n), KOKKOS_LAMBDA(const int p) {
        // A = I + E and B = I + E' with |E| small: well conditioned (cond < 4), so inverses are accurate.
        M a = M::identity(), b = M::identity();
        Vec3<real_t> x;
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) {
            a(i, j) += entries(21 * p + 3 * i + j);
            b(i, j) += entries(21 * p + 9 + 3 * i + j);
          }
          x[i] = entries(21 * p + 18 + i);
        }
        residual(p, 0) = frobenius_norm(a * inverse(a) - M::identity());
        residual(p, 1) = math::fabs(determinant(a * b) - determinant(a) * determinant(b));
        residual(p, 2) = frobenius_norm(cofactor(a) - determinant(a) * transpose(inverse(a)));
        residual(p, 3) = frobenius_norm(a * transpose(b) - multiply_transposed(a, b));
        residual(p, 4) = frobenius_norm(transpose(transpose(a)) - a);
        residual(p, 5) = norm(a * (b * x) - (a * b) * x);
        residual(p, 6) = math::fabs(ddot(a, b) - trace(transpose(a) * b));
      });
  auto h = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), residual);
  // Each entry is a sum of a few products of O(1) numbers: rounding leaves at most ~10 eps per entry; inversion
  // multiplies that by the condition number (< 4). 100 eps bounds all of them with margin.
  const double tol = 100 * eps;
  for (int p = 0; p < n; ++p) {
    EXPECT_LT(h(p, 0), tol) << "A A^-1 != I for matrix " << p;
    EXPECT_LT(h(p, 1), tol) << "det(AB) != det(A) det(B) for matrix " << p;
    EXPECT_LT(h(p, 2), tol) << "cofactor for matrix " << p;
    EXPECT_LT(h(p, 3), tol) << "multiply_transposed for matrix " << p;
    EXPECT_EQ(h(p, 4), 0.0) << "transpose is not an involution for matrix " << p;
    EXPECT_LT(h(p, 5), tol) << "matrix products are not associative for matrix " << p;
    EXPECT_LT(h(p, 6), tol) << "A:B != tr(A^T B) for matrix " << p;
  }
}

template <class ExecutionSpace>
class Mat3Test : public ::testing::Test {};
TYPED_TEST_SUITE(Mat3Test, EnabledBackends, BackendName);

TYPED_TEST(Mat3Test, AlgebraicIdentities) { check_identities<TypeParam>(); }

TEST(Mat3Host, KnownValues) {
  // A rotation by 90 degrees about z composed with a stretch: det = product of stretches.
  M r = M::zero();
  r(0, 1) = -1;
  r(1, 0) = 1;
  r(2, 2) = 1;
  const M f = r * M::diagonal(2, 3, 4);
  EXPECT_DOUBLE_EQ(determinant(f), 24.0);
  EXPECT_DOUBLE_EQ(trace(M::diagonal(2, 3, 4)), 9.0);
  const Vec3<real_t> ex{{1, 0, 0}}, ey{{0, 1, 0}};
  const auto ez = cross(ex, ey);
  EXPECT_EQ(ez[2], 1);
  EXPECT_EQ(dot(ez, ex), 0);
}

}  // namespace
}  // namespace mpmrom::test
