// Quadratic B-spline weights: partition of unity, linear completeness, and gradients against finite differences.
#include <cmath>

#include "backends.hpp"
#include "mpm/bspline.hpp"

namespace mpmrom::test {
namespace {

KOKKOS_INLINE_FUNCTION Vec3<double> x_as_double(const Vec3<real_t>& x) { return {{x[0], x[1], x[2]}}; }

// Per point: |sum N_i - 1|, |sum N_i x_i - x|, |sum grad N_i|, |sum x_i (x) grad N_i - I|, and the largest
// difference between grad N_i and a central finite difference of N_i (NaN where the difference crosses a knot).
template <class ExecutionSpace>
void check_bspline(double dx, double h_cells) {
  const int n = 4000;
  const real_t origin_value = -0.37;
  // Points within a few cells of the origin, so that rounding of x itself stays at the level of eps * dx.
  auto coords = random_view<ExecutionSpace>("coords", 3 * n, origin_value + 2 * dx, origin_value + 6 * dx, 11);
  Kokkos::View<double* [5], typename ExecutionSpace::memory_space> residual("residual", n);
  const real_t rdx = dx, inv_dx = real_t(1) / rdx, h = real_t(h_cells * dx);
  Kokkos::parallel_for(
      "mpmrom::test::bspline", Kokkos::RangePolicy<ExecutionSpace>(0, n), KOKKOS_LAMBDA(const int p) {
        const Vec3<real_t> origin{{origin_value, origin_value, origin_value}};
        const Vec3<real_t> x{{coords(3 * p), coords(3 * p + 1), coords(3 * p + 2)}};
        const auto s = quadratic_stencil(x, origin, inv_dx);
        double sum_w = 0, fd_error = 0;
        Vec3<double> sum_wx{{0, 0, 0}}, sum_grad{{0, 0, 0}};
        Mat3<double> sum_x_grad = Mat3<double>::zero();
        bool crosses_knot = false;
        for (int a = 0; a < 3; ++a)
          for (int b = 0; b < 3; ++b)
            for (int c = 0; c < 3; ++c) {
              const real_t w = s.weight(a, b, c);
              const auto g = s.gradient(a, b, c);
              const Vec3<real_t> node{{origin[0] + (s.base[0] + a) * rdx, origin[1] + (s.base[1] + b) * rdx,
                                       origin[2] + (s.base[2] + c) * rdx}};
              sum_w += w;
              for (int d = 0; d < 3; ++d) {
                sum_wx[d] += double(w) * node[d];
                sum_grad[d] += g[d];
                for (int e = 0; e < 3; ++e) sum_x_grad(d, e) += double(node[d]) * g[e];
              }
              for (int d = 0; d < 3; ++d) {
                Vec3<real_t> xp = x, xm = x;
                xp[d] += h;
                xm[d] -= h;
                const auto sp = quadratic_stencil(xp, origin, inv_dx);
                const auto sm = quadratic_stencil(xm, origin, inv_dx);
                if (sp.base[d] != s.base[d] || sm.base[d] != s.base[d]) {
                  crosses_knot = true;
                  continue;
                }
                const double fd = (double(sp.weight(a, b, c)) - double(sm.weight(a, b, c))) / (double(xp[d]) - xm[d]);
                fd_error = math::max(fd_error, math::fabs(fd - double(g[d])) * rdx);
              }
            }
        residual(p, 0) = math::fabs(sum_w - 1);
        residual(p, 1) = norm(sum_wx - x_as_double(x)) / rdx;
        residual(p, 2) = norm(sum_grad) * rdx;
        residual(p, 3) = frobenius_norm(sum_x_grad - Mat3<double>::identity());
        residual(p, 4) = crosses_knot ? -1.0 : fd_error;
      });
  auto r = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), residual);
  // Sums of 27 products of three O(1) weights: rounding stays below ~30 eps. Positions are O(10) cells from zero,
  // so completeness (in cells) carries ~10x more.
  const double sum_tol = 64 * eps, completeness_tol = 512 * eps;
  // Each weight is quadratic in each coordinate within a knot span, so the central difference has no truncation
  // error; what remains is cancellation: each weight carries ~10 eps of rounding, and the difference of two of them
  // is divided by 2h (in cells): ~10 eps / h_cells, taken with a margin of 6.
  const double fd_tol = 64 * eps / h_cells;
  int fd_checked = 0;
  for (int p = 0; p < n; ++p) {
    EXPECT_LT(r(p, 0), sum_tol) << "partition of unity, point " << p;
    EXPECT_LT(r(p, 1), completeness_tol) << "linear completeness, point " << p;
    EXPECT_LT(r(p, 2), sum_tol * 8) << "gradients sum to zero, point " << p;
    EXPECT_LT(r(p, 3), completeness_tol) << "sum x_i grad N_i = I, point " << p;
    if (r(p, 4) >= 0) {
      ++fd_checked;
      EXPECT_LT(r(p, 4), fd_tol) << "gradient against finite difference, point " << p;
    }
  }
  EXPECT_GT(fd_checked, n / 2) << "too few points away from knots were checked";
}

template <class ExecutionSpace>
class BSpline : public ::testing::Test {};
TYPED_TEST_SUITE(BSpline, EnabledBackends, BackendName);

TYPED_TEST(BSpline, UnityCompletenessAndGradients) {
  // Finite-difference step: large enough that cancellation is small in float, small enough to rarely cross a knot.
  const double h_cells = std::is_same<real_t, float>::value ? 1e-2 : 1e-4;
  check_bspline<TypeParam>(0.05, h_cells);
  check_bspline<TypeParam>(1.0, h_cells);
}

// gradient_component is gradient's entry, the same products in the same order: equal bit for bit.
TEST(BSplineHost, GradientComponentIsTheGradientsEntry) {
  const Vec3<real_t> origin{{real_t(-0.3), real_t(0.1), real_t(0.7)}};
  for (const real_t t : {real_t(0.0), real_t(0.37), real_t(1.91), real_t(-2.45)}) {
    const auto s = quadratic_stencil(Vec3<real_t>{{t, real_t(0.5) * t + 1, 3 - t}}, origin, real_t(4));
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b)
        for (int c = 0; c < 3; ++c)
          for (int axis = 0; axis < 3; ++axis)
            EXPECT_EQ(s.gradient_component(a, b, c, axis), s.gradient(a, b, c)[axis]) << a << b << c << axis;
  }
}

TEST(BSplineHost, KnownValuesAtNodeAndMidpoint) {
  const Vec3<real_t> origin{{0, 0, 0}};
  // At a node the 1D weights are (1/8, 3/4, 1/8); midway between nodes (1/2, 1/2, 0).
  const auto at_node = quadratic_stencil(Vec3<real_t>{{2, 2, 2}}, origin, real_t(1));
  EXPECT_EQ(at_node.base[0], 1);
  EXPECT_NEAR(at_node.w[0][0], 0.125, 4 * eps);
  EXPECT_NEAR(at_node.w[0][1], 0.75, 4 * eps);
  EXPECT_NEAR(at_node.w[0][2], 0.125, 4 * eps);
  const auto midway = quadratic_stencil(Vec3<real_t>{{2.5, 2.5, 2.5}}, origin, real_t(1));
  EXPECT_EQ(midway.base[0], 2);
  EXPECT_NEAR(midway.w[0][0], 0.5, 4 * eps);
  EXPECT_NEAR(midway.w[0][1], 0.5, 4 * eps);
  EXPECT_NEAR(midway.w[0][2], 0.0, 4 * eps);
}

}  // namespace
}  // namespace mpmrom::test
