// The reduced model's projection: the guarded normal-equation solve and the projection kernel (mass-weighted,
// damped, Gauss-Newton on positions) against Eigen, and the position passes on a curved manifold.
#include <Eigen/Dense>

#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "backends.hpp"
#include "rom/kernels/projection.hpp"

namespace mpmrom::test {
namespace {

constexpr double eps = std::numeric_limits<real_t>::epsilon();

// ---------------------------------------------------------------------------------------------------------------
// The guarded r x r solve of the projection against Eigen.
struct SolveOutcome {
  std::vector<double> x;
  int flags;
  double condition;
};

SolveOutcome guarded_solve(const Eigen::MatrixXd& A, const Eigen::VectorXd& b, const rom::ProjectionGuard& guard) {
  SolveOutcome out{{}, -1, 0};
  rom::with_latent_dim(int(A.rows()), [&](auto R) {
    constexpr int r = decltype(R)::value;
    real_t a[r][r], rhs[2][r] = {}, x[2][r] = {};
    for (int i = 0; i < r; ++i) {
      rhs[0][i] = real_t(b(i));
      for (int j = 0; j < r; ++j) a[i][j] = real_t(A(i, j));
    }
    real_t condition = 0;
    out.flags = rom::SerialGuardedSolve<r>(a, rhs, guard, x, condition, 1);
    out.x.assign(x[0], x[0] + r);
    out.condition = double(condition);
  });
  return out;
}

rom::ProjectionGuard default_guard() {
  rom::ProjectionGuard guard;
  guard.max_condition = real_t(0.01 / eps);
  guard.regularization = real_t(100 * eps);
  return guard;
}

TEST(RomProjection, WellConditionedNormalEquationsMatchEigen) {
  std::mt19937 gen(7);
  std::normal_distribution<double> normal(0, 1);
  for (int r : {1, 5, 12, 16}) {
    Eigen::MatrixXd J(3 * 15 + r, r);
    for (int i = 0; i < J.rows(); ++i)
      for (int j = 0; j < J.cols(); ++j) J(i, j) = normal(gen);
    const Eigen::MatrixXd A = J.transpose() * J;
    const Eigen::VectorXd b = J.transpose() * Eigen::VectorXd::NullaryExpr(J.rows(), [&]() { return normal(gen); });
    const Eigen::VectorXd expected = A.ldlt().solve(b);
    const auto out = guarded_solve(A, b, default_guard());
    EXPECT_EQ(out.flags, 0) << "r = " << r;
    // Cholesky is backward stable: forward error <= c r eps cond(A) |x|; cond(A) of a 61 x 16 Gaussian J^T J < 100.
    const double cond = Eigen::JacobiSVD<Eigen::MatrixXd>(A).singularValues()(0) /
                        Eigen::JacobiSVD<Eigen::MatrixXd>(A).singularValues()(r - 1);
    for (int i = 0; i < r; ++i) EXPECT_NEAR(out.x[i], expected(i), 10 * r * eps * cond * expected.norm()) << r;
    // The estimate (max L_ii / min L_ii)^2 is a lower bound of cond_2(A).
    EXPECT_LE(out.condition, cond * (1 + 1e-6));
  }
}

TEST(RomProjection, IllConditionedSystemsAreRegularisedAndFlaggedNeverNaN) {
  std::mt19937 gen(11);
  std::normal_distribution<double> normal(0, 1);
  const int r = 5;
  // Two nearly equal columns: cond(A) ~ 1e20, beyond any precision's limit.
  Eigen::MatrixXd J(45, r);
  for (int i = 0; i < J.rows(); ++i)
    for (int j = 0; j < r; ++j) J(i, j) = normal(gen);
  J.col(4) = J.col(3) * (1 + 1e-10);
  const Eigen::MatrixXd A = J.transpose() * J;
  const Eigen::VectorXd b = J.transpose() * Eigen::VectorXd::NullaryExpr(J.rows(), [&]() { return normal(gen); });
  const rom::ProjectionGuard guard = default_guard();
  const auto out = guarded_solve(A, b, guard);
  EXPECT_TRUE(out.flags & rom::flag_ill_conditioned);
  EXPECT_FALSE(out.flags & rom::fatal_flags);
  // It solved the regularised system (A + mu I) x = b: backward-stable residual relative to |A + mu I| |x|.
  const double mu = double(guard.regularization) * A.trace() / r;
  const Eigen::MatrixXd regularised = A + mu * Eigen::MatrixXd::Identity(r, r);
  Eigen::VectorXd x(r);
  for (int i = 0; i < r; ++i) {
    ASSERT_TRUE(std::isfinite(out.x[i]));
    x(i) = out.x[i];
  }
  EXPECT_LE((regularised * x - b).norm(), 100 * r * eps * (regularised.norm() * x.norm() + b.norm()));

  // A zero system (no sample moves the manifold) cannot be regularised relative to its trace: flagged singular.
  const auto singular = guarded_solve(Eigen::MatrixXd::Zero(r, r), Eigen::VectorXd::Ones(r), guard);
  EXPECT_TRUE(singular.flags & rom::flag_singular);
  // A NaN in the transferred velocities is caught, not passed on.
  Eigen::VectorXd nan_rhs = b;
  nan_rhs(2) = std::nan("");
  const auto not_finite = guarded_solve(A.topLeftCorner(3, 3), nan_rhs.head(3), guard);
  EXPECT_TRUE(not_finite.flags & rom::flag_not_finite);
}

// ---------------------------------------------------------------------------------------------------------------
// One pass of the projection kernel on the default execution space, its inputs and outputs on the host.
struct ProjectionPass {
  int B, S, r;
  std::vector<double> weight, J, v, x_n, x_eval;  // (S), (B, S, 3, r), (B, S, 3) x 3
  std::vector<double> xhat, xhatdot, xhat_next;   // (B, r); xhat_next: the evaluated state
  double damping = 0, dt = 0.01;

  // Runs the kernel (a team per rollout, or one_thread: a thread per rollout, as large GPU batches run it); returns
  // (xhat_next, xhatdot_next) (B, r) each and the flags.
  std::pair<std::vector<double>, std::vector<double>> run(bool first_pass, bool positions, int& flags,
                                                          bool one_thread = false) const {
    using Space = Kokkos::DefaultExecutionSpace;
    using Memory = Space::memory_space;
    const auto upload = [](const std::vector<double>& values, auto view) {
      auto host = Kokkos::create_mirror_view(view);
      for (std::size_t i = 0; i < values.size(); ++i) host.data()[i] = real_t(values[i]);
      Kokkos::deep_copy(view, host);
      return view;
    };
    const auto download = [](auto view) {
      auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), view);
      return std::vector<double>(host.data(), host.data() + host.size());
    };
    rom::ProjectSamples<Space, Memory> pass{r,
                                            upload(weight, Kokkos::View<real_t*, Memory>("w", S)),
                                            upload(J, rom::BatchJacobians<Memory>("J", B, S, 3, r)),
                                            upload(v, rom::BatchVectors<Memory>("v", B, S, 3)),
                                            upload(x_n, rom::BatchVectors<Memory>("x_n", B, S, 3)),
                                            upload(x_eval, rom::BatchVectors<Memory>("x_eval", B, S, 3)),
                                            upload(xhat, rom::BatchMatrix<Memory>("xhat", B, r)),
                                            upload(xhatdot, rom::BatchMatrix<Memory>("xhatdot", B, r)),
                                            upload(xhat_next, rom::BatchMatrix<Memory>("xhat_next", B, r)),
                                            rom::BatchMatrix<Memory>("xhatdot_next", B, r),
                                            default_guard(),
                                            real_t(damping),
                                            real_t(dt),
                                            first_pass,
                                            positions,
                                            Kokkos::View<int*, Memory>("flags", B),
                                            Kokkos::View<real_t*, Memory>("condition", B),
                                            Kokkos::View<int*, Memory>("regularized", B)};
    const int lanes = Kokkos::SpaceAccessibility<Kokkos::HostSpace, Memory>::accessible ? 1 : 32;
    if (one_thread)
      Kokkos::parallel_for(Kokkos::RangePolicy<Space>(0, B), pass);
    else
      Kokkos::parallel_for(Kokkos::TeamPolicy<Space>(B, Kokkos::AUTO, lanes)
                               .set_scratch_size(0, Kokkos::PerTeam(decltype(pass)::scratch_bytes())),
                           pass);
    flags = 0;
    for (const double f : download(pass.flags)) flags |= int(f);
    return {download(pass.xhat_next), download(pass.xhatdot_next)};
  }
};

// Mass-weighted, damped fit and the Gauss-Newton position step against Eigen's solution of the same normal equations:
// (A + lambda I) y = rhs, A = J^T W J, lambda = damping * trace(A) / r, rhs_rate = J^T W v + lambda xhatdot_n and
// rhs_step = J^T W (x_n + dt v - x_eval); a team per rollout and a thread per rollout.
TEST(RomProjection, WeightedDampedFitAndPositionStepMatchEigen) {
  std::mt19937 gen(5);
  std::normal_distribution<double> normal(0, 1);
  std::uniform_real_distribution<double> mass(0.5, 2.0);
  ProjectionPass p{3, 7, 4};
  const auto fill = [&](std::vector<double>& values, std::size_t n) {
    values.resize(n);
    for (double& value : values) value = normal(gen);
  };
  p.weight.resize(p.S);
  for (double& w : p.weight) w = mass(gen);
  fill(p.J, std::size_t(p.B * p.S * 3 * p.r));
  fill(p.v, std::size_t(p.B * p.S * 3));
  fill(p.x_n, p.v.size());
  fill(p.x_eval, p.v.size());
  fill(p.xhat, std::size_t(p.B * p.r));
  fill(p.xhatdot, p.xhat.size());
  fill(p.xhat_next, p.xhat.size());
  for (const double damping : {0.0, 0.3}) {
    p.damping = damping;
    for (const auto& [positions, one_thread] : {std::pair{false, false}, {true, false}, {false, true}, {true, true}}) {
      int flags = 0;
      const auto [xhat_next, xhatdot_next] = p.run(!positions, positions, flags, one_thread);
      ASSERT_EQ(flags & rom::fatal_flags, 0);
      for (int b = 0; b < p.B; ++b) {
        Eigen::MatrixXd A = Eigen::MatrixXd::Zero(p.r, p.r);
        Eigen::VectorXd rate_rhs = Eigen::VectorXd::Zero(p.r), step_rhs = rate_rhs;
        for (int s = 0; s < p.S; ++s)
          for (int k = 0; k < 3; ++k) {
            const std::size_t row = std::size_t((b * p.S + s) * 3 + k);
            const Eigen::Map<const Eigen::VectorXd> Jrow(&p.J[row * p.r], p.r);
            A += p.weight[s] * Jrow * Jrow.transpose();
            rate_rhs += p.weight[s] * p.v[row] * Jrow;
            step_rhs += p.weight[s] * (p.x_n[row] + p.dt * p.v[row] - p.x_eval[row]) * Jrow;
          }
        const double lambda = damping * A.trace() / p.r;
        const Eigen::Map<const Eigen::VectorXd> xhat(&p.xhat[b * p.r], p.r), xhatdot(&p.xhatdot[b * p.r], p.r),
            evaluated(&p.xhat_next[b * p.r], p.r);
        A.diagonal().array() += lambda;
        const Eigen::VectorXd rate = A.llt().solve(rate_rhs + lambda * xhatdot);
        const Eigen::VectorXd next =
            positions ? Eigen::VectorXd(evaluated + A.llt().solve(step_rhs)) : Eigen::VectorXd(xhat + p.dt * rate);
        // Backward-stable Cholesky (forward error <= c r eps cond |y|) on sums of 21 O(1) rows, with room for both.
        const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A);
        const double cond = svd.singularValues()(0) / svd.singularValues()(p.r - 1);
        const double tolerance = 100 * p.r * eps * cond;
        for (int q = 0; q < p.r; ++q) {
          EXPECT_NEAR(xhatdot_next[b * p.r + q], rate(q), tolerance * (1 + rate.norm()))
              << damping << positions << one_thread;
          EXPECT_NEAR(xhat_next[b * p.r + q], next(q), tolerance * (1 + next.norm()))
              << damping << positions << one_thread;
        }
      }
    }
  }
}

// The position scheme's passes are Gauss-Newton on the samples' misfit: on a curved manifold (a rotation about z,
// g(X; theta) = R(theta) X, r = 1) with targets on it, the angle converges to the targets' quadratically (a
// zero-residual problem), where the velocity scheme's integrated rate would leave it at theta + dt * rate.
TEST(RomProjection, PositionPassesConvergeOntoTargetsOnACurvedManifold) {
  const double target = 0.4;
  double theta = target + 0.3;
  ProjectionPass p{1, 5, 1};
  p.weight.assign(p.S, 1.0);
  p.v.assign(std::size_t(p.S * 3), 0.0);  // targets x_n + dt v = R(target) X
  p.xhat = {0.0};
  p.xhatdot = {0.0};
  const std::vector<double> X = {1, 0, 0, 0, 1, 0.2, -1, 0.5, 0, 0.3, -0.7, 1, 0.6, 0.6, -0.4};
  // Positions R(angle) X and, if asked, their derivative along the angle (the Jacobian's one column).
  const auto rotate = [&](double angle, std::vector<double>& x, std::vector<double>* dxdangle) {
    const double c = std::cos(angle), s = std::sin(angle);
    x.resize(X.size());
    if (dxdangle) dxdangle->assign(X.size(), 0.0);
    for (std::size_t i = 0; i < X.size(); i += 3) {
      x[i] = c * X[i] - s * X[i + 1];
      x[i + 1] = s * X[i] + c * X[i + 1];
      x[i + 2] = X[i + 2];
      if (!dxdangle) continue;
      (*dxdangle)[i] = -s * X[i] - c * X[i + 1];
      (*dxdangle)[i + 1] = c * X[i] - s * X[i + 1];
    }
  };
  rotate(target, p.x_n, nullptr);
  std::vector<double> errors;
  for (int iteration = 0; iteration < 6; ++iteration) {
    rotate(theta, p.x_eval, &p.J);
    p.xhat_next = {theta};
    int flags = 0;
    theta = p.run(false, true, flags).first[0];
    ASSERT_EQ(flags & rom::fatal_flags, 0);
    errors.push_back(std::fabs(theta - target));
  }
  // Quadratic: each error at most a constant times the square of the one before (the constant, curvature over
  // slope, is 1 for a rotation) until rounding, which leaves the angle within a few eps.
  for (std::size_t k = 1; k < errors.size(); ++k) EXPECT_LE(errors[k], 2 * errors[k - 1] * errors[k - 1] + 10 * eps);
  EXPECT_LE(errors.back(), 10 * eps);
}

}  // namespace
}  // namespace mpmrom::test
