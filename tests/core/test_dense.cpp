// Host dense algebra: the small Cholesky solve (the projection's normal equations) against systems with a known
// solution, with runtime and compile-time loop bounds; non-negative least squares (the reduced model's cubature
// weights) against its optimality conditions and against problems with a known solution; the generalised symmetric
// eigenvalue (the reduced model's highest frequency) against matrices built from known eigenvalues.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/math/cholesky.hpp"
#include "core/math/nnls.hpp"
#include "core/math/symmetric_eigen.hpp"

namespace mpmrom::test {
namespace {

struct Problem {
  std::size_t m, n;
  std::vector<double> E, f, G, h;  // E (m x n) row-major; G = E^T E, h = E^T f
};

Problem random_problem(std::size_t m, std::size_t n, unsigned seed, const std::vector<double>* exact = nullptr) {
  std::mt19937 gen(seed);
  std::normal_distribution<double> normal(0, 1);
  Problem p{m,
            n,
            std::vector<double>(m * n),
            std::vector<double>(m),
            std::vector<double>(n * n, 0.0),
            std::vector<double>(n, 0.0)};
  for (double& e : p.E) e = normal(gen);
  for (std::size_t i = 0; i < m; ++i) {
    p.f[i] = exact ? 0.0 : normal(gen);
    if (exact)
      for (std::size_t j = 0; j < n; ++j) p.f[i] += p.E[i * n + j] * (*exact)[j];
  }
  for (std::size_t i = 0; i < m; ++i)
    for (std::size_t a = 0; a < n; ++a) {
      p.h[a] += p.E[i * n + a] * p.f[i];
      for (std::size_t b = 0; b < n; ++b) p.G[a * n + b] += p.E[i * n + a] * p.E[i * n + b];
    }
  return p;
}

// A = B B^T + n I for a random B and b = A x for a known x, every n up to 16 in a 16 x 16 array: both bounds give the
// same factor to the bit (the same operations in the same order) and x back. Tolerance: A's eigenvalues lie in
// [n, n + |B|^2] with |B| about 2, so its condition number is below 5 and the solve's error near 5 n eps |x|.
TEST(Cholesky, RuntimeAndCompileTimeBoundsSolveTheSameSystems) {
  constexpr int lda = 16;
  std::mt19937 gen(7);
  std::normal_distribution<double> normal(0, 1);
  for (int n = 1; n <= lda; ++n) {
    std::vector<double> B(n * n), A(lda * lda, -1.0), x(n), b(lda, 1e30);  // beyond n: never to be read
    for (double& e : B) e = normal(gen) / std::sqrt(double(n));
    for (double& e : x) e = normal(gen);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        A[i * lda + j] = i == j ? double(n) : 0.0;
        for (int k = 0; k < n; ++k) A[i * lda + j] += B[i * n + k] * B[j * n + k];
      }
    for (int i = 0; i < n; ++i) {
      b[i] = 0;
      for (int j = 0; j < n; ++j) b[i] += A[i * lda + j] * x[j];
    }
    std::vector<double> L_runtime = A, L_bounded = A, x_runtime = b, x_bounded = b;
    ASSERT_TRUE(dense::SerialCholesky(L_runtime.data(), n, lda));
    ASSERT_TRUE(dense::SerialCholesky<lda>(L_bounded.data(), n, lda));
    EXPECT_EQ(L_runtime, L_bounded) << "n = " << n;
    dense::SerialCholeskySolve(L_runtime.data(), n, lda, x_runtime.data());
    dense::SerialCholeskySolve<lda>(L_bounded.data(), n, lda, x_bounded.data());
    EXPECT_EQ(x_runtime, x_bounded) << "n = " << n;
    for (int i = 0; i < n; ++i) EXPECT_NEAR(x_bounded[i], x[i], 1e-12 * (1 + std::abs(x[i]))) << "n = " << n;
  }
}

// A symmetric matrix with a negative eigenvalue (a pivot that is not positive) is refused with either bound.
TEST(Cholesky, IndefiniteMatrixIsRefused) {
  constexpr int lda = 16;
  std::vector<double> A(lda * lda, 0.0);
  A[0] = 4;
  A[1] = A[lda] = 3;
  A[lda + 1] = 1;  // det = 4 - 9 < 0
  std::vector<double> L = A;
  EXPECT_FALSE(dense::SerialCholesky(L.data(), 2, lda));
  L = A;
  EXPECT_FALSE(dense::SerialCholesky<lda>(L.data(), 2, lda));
}

// Karush-Kuhn-Tucker: w >= 0, the gradient h - G w vanishes where w > 0 and points outward (<= 0) where w = 0. The
// tolerance: the passive solves' ridge (1e-12 of G's diagonal) and rounding of n-term sums, far below 1e-9 |h|.
TEST(Nnls, SolutionsMeetTheOptimalityConditions) {
  for (unsigned seed = 1; seed <= 20; ++seed) {
    const Problem p = random_problem(30, 12, seed);
    const std::vector<double> w = dense::nnls_normal(p.G, p.h, p.n);
    double scale = 0;
    for (const double x : p.h) scale = std::max(scale, std::fabs(x));
    int positive = 0;
    for (std::size_t i = 0; i < p.n; ++i) {
      ASSERT_GE(w[i], 0.0);
      double gradient = p.h[i];
      for (std::size_t j = 0; j < p.n; ++j) gradient -= p.G[i * p.n + j] * w[j];
      if (w[i] > 0) {
        ++positive;
        EXPECT_NEAR(gradient, 0.0, 1e-9 * scale) << "seed " << seed << " unknown " << i;
      } else {
        EXPECT_LE(gradient, 1e-9 * scale) << "seed " << seed << " unknown " << i;
      }
    }
    EXPECT_GT(positive, 0);  // random f has a descent direction into the positive orthant
  }
}

// A consistent system with a non-negative solution (some entries 0) and full column rank: the minimiser is that
// solution, found to the conditioning of the normal equations (cond(E)^2 of a 40 x 10 Gaussian E, below 1e2).
TEST(Nnls, ConsistentSystemGivesItsNonNegativeSolution) {
  const std::vector<double> exact = {0.5, 0, 2, 0, 0.1, 3, 0, 1, 0.7, 0};
  const Problem p = random_problem(40, exact.size(), 3, &exact);
  const std::vector<double> w = dense::nnls_normal(p.G, p.h, p.n);
  for (std::size_t i = 0; i < p.n; ++i) EXPECT_NEAR(w[i], exact[i], 1e-8) << i;
}

// A cap on the positive unknowns stops the active set there; each larger cap continues the same path, so the
// objective never rises.
TEST(Nnls, CapOnPositiveUnknownsIsRespectedAndObjectiveFallsWithIt) {
  const Problem p = random_problem(60, 40, 9);
  double previous = std::numeric_limits<double>::infinity();
  for (const std::size_t cap : {1, 2, 4, 8, 16}) {
    const std::vector<double> w = dense::nnls_normal(p.G, p.h, p.n, cap);
    EXPECT_LE(std::size_t(std::count_if(w.begin(), w.end(), [](double x) { return x > 0; })), cap);
    double objective = 0;  // |E w - f|^2
    for (std::size_t i = 0; i < p.m; ++i) {
      double e = -p.f[i];
      for (std::size_t j = 0; j < p.n; ++j) e += p.E[i * p.n + j] * w[j];
      objective += e * e;
    }
    EXPECT_LE(objective, previous * (1 + 1e-12)) << cap;
    previous = objective;
  }
}

// K = L Q D Q^T L^T with M = L L^T (L random lower triangular, Q random orthogonal) has the eigenvalues D against M,
// whatever antisymmetric part is added to K (only its symmetric part counts, as for a finite-difference stiffness);
// Jacobi rotations converge to 1e-15 of the norm, so 1e-10 relative is far above rounding. An M that is not positive
// definite gives -infinity.
TEST(GeneralisedEigenvalue, LargestOfKnownSpectraAgainstAMassMatrix) {
  std::mt19937 gen(7);
  std::normal_distribution<double> normal(0, 1);
  for (const int n : {1, 3, 5, 8}) {
    std::vector<double> L(std::size_t(n * n), 0.0), Q(std::size_t(n * n));
    for (int i = 0; i < n; ++i)
      for (int j = 0; j <= i; ++j) L[std::size_t(i * n + j)] = i == j ? 1 + std::fabs(normal(gen)) : normal(gen);
    for (double& q : Q) q = normal(gen);
    for (int c = 0; c < n; ++c) {  // Gram-Schmidt on Q's columns
      for (int k = 0; k < c; ++k) {
        double dot = 0;
        for (int i = 0; i < n; ++i) dot += Q[std::size_t(i * n + c)] * Q[std::size_t(i * n + k)];
        for (int i = 0; i < n; ++i) Q[std::size_t(i * n + c)] -= dot * Q[std::size_t(i * n + k)];
      }
      double norm = 0;
      for (int i = 0; i < n; ++i) norm += Q[std::size_t(i * n + c)] * Q[std::size_t(i * n + c)];
      for (int i = 0; i < n; ++i) Q[std::size_t(i * n + c)] /= std::sqrt(norm);
    }
    std::vector<double> D(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) D[std::size_t(i)] = 100 * normal(gen);  // of both signs
    const double largest = *std::max_element(D.begin(), D.end());
    std::vector<double> LQ(std::size_t(n * n), 0.0), K(std::size_t(n * n), 0.0), M(std::size_t(n * n), 0.0);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k) {
          LQ[std::size_t(i * n + j)] += L[std::size_t(i * n + k)] * Q[std::size_t(k * n + j)];
          M[std::size_t(i * n + j)] += L[std::size_t(i * n + k)] * L[std::size_t(j * n + k)];
        }
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        for (int k = 0; k < n; ++k)
          K[std::size_t(i * n + j)] += LQ[std::size_t(i * n + k)] * D[std::size_t(k)] * LQ[std::size_t(j * n + k)];
    EXPECT_NEAR(dense::largest_generalised_eigenvalue(K, M, n), largest, 1e-10 * 100) << n;
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) {
        const double a = normal(gen);
        K[std::size_t(i * n + j)] += a;
        K[std::size_t(j * n + i)] -= a;
      }
    EXPECT_NEAR(dense::largest_generalised_eigenvalue(K, M, n), largest, 1e-10 * 100) << n << " antisymmetric part";
    M[0] = -1;
    EXPECT_EQ(dense::largest_generalised_eigenvalue(K, M, n), -std::numeric_limits<double>::infinity()) << n;
  }
}

}  // namespace
}  // namespace mpmrom::test
