// The projection (Algorithm 1 step 6, Algorithm 2 step 8), per rollout, over the sample points s with weights w_s
// (their masses) and J_s = dg/dxhat at the latent state the pass evaluates:
//   velocity: xhatdot minimises sum_s w_s |J_s xhatdot - v_s|^2 + lambda |xhatdot - xhatdot_n|^2, the samples'
//     transferred velocities v_s fitted in the tangent space. lambda = rate_damping * trace(J^T W J) / r (Tikhonov
//     toward the previous rate; 0: the paper's fit) damps only directions the samples hardly see.
//   position (the scheme "position", passes after the first): also a Gauss-Newton step for xhat minimising
//     sum_s w_s |g(X_s; xhat) - (x_s(t_n) + dt v_s)|^2 from the evaluated state, on the same normal matrix, so that
//     the samples land where the full-order update would put them; the velocity scheme takes xhat_n + dt xhatdot.
// Both through the normal equations (J^T W J + lambda I) y = J^T W rhs. The first pass evaluates J at xhat(t_n);
// further passes at the state the previous one produced (docs/rom.md says why).
//
// Parallelism: one team per rollout; team thread i takes row i of J^T W J and of the right-hand sides, one
// parallel_reduce over the samples' rows across its vector lanes; one thread then factors and solves the r x r system
// in registers (r made a compile-time constant by with_latent_dim; core/math/cholesky.hpp). Or (a RangePolicy) one
// thread per rollout for all of it. Guard: the condition number is
// estimated from the Cholesky factor as (max L_ii / min L_ii)^2 (a lower bound of cond_2); above max_condition, or when
// the factorisation fails, the system is regularised with mu I, mu = regularization * trace / r, and the rollout
// flagged; if that fails too, or the solution is not finite, the rollout is flagged and its state left as it was, never
// set to NaN. With regularisation off, an ill-conditioned system stops the rollout instead (flag_ill_posed). A
// projected latent speed |xhatdot| above max_latent_speed stops it too (flag_energy): the reduced kinetic energy has
// left every bound the training motion sets.
#pragma once

#include "core/math/cholesky.hpp"
#include "rom/kernels/sources.hpp"

namespace mpmrom::rom {

// Flags after which a rollout no longer advances.
inline constexpr int fatal_flags = flag_inverted | flag_not_finite | flag_left_node_set | flag_singular |
                                   flag_ill_posed | flag_energy | flag_inversion;

struct ProjectionGuard {
  real_t max_condition = 0;   // regularise (or, with regularize false, stop) above this condition estimate
  real_t regularization = 0;  // mu = regularization * trace(J^T J) / r
  bool regularize = true;
  real_t max_latent_speed = 0;  // 0: no limit
};

// Solves A x = rhs for the R x R SPD matrix A and `columns` (1 or 2) right-hand sides with the guard above, all in
// local arrays of compile-time size (registers on GPUs). Returns the flags raised; condition receives the estimate of
// the system actually solved. Parallelism contract: one thread.
template <int R>
KOKKOS_INLINE_FUNCTION int SerialGuardedSolve(const real_t (&A)[R][R], const real_t (&rhs)[2][R],
                                              const ProjectionGuard& guard, real_t (&x)[2][R], real_t& condition,
                                              int columns) {
  real_t trace = 0;
  MPMROM_UNROLL
  for (int i = 0; i < R; ++i) trace += A[i][i];
  int flags = 0;
  for (int attempt = 0; attempt < 2; ++attempt) {
    const real_t mu = attempt == 0 ? real_t(0) : guard.regularization * trace / real_t(R);
    real_t L[R][R];
    MPMROM_UNROLL
    for (int i = 0; i < R; ++i) {
      MPMROM_UNROLL
      for (int j = 0; j < R; ++j) L[i][j] = j <= i ? A[i][j] + (i == j ? mu : real_t(0)) : real_t(0);
    }
    bool ok = dense::SerialCholeskyFixed<R>(L);
    if (ok) {
      real_t lo = L[0][0], hi = L[0][0];
      MPMROM_UNROLL
      for (int i = 1; i < R; ++i) {
        lo = math::min(lo, L[i][i]);
        hi = math::max(hi, L[i][i]);
      }
      condition = (hi / lo) * (hi / lo);
      ok = attempt == 1 || condition <= guard.max_condition;
    }
    if (!ok && !guard.regularize) return flags | flag_ill_conditioned | flag_ill_posed;
    if (ok) {
      MPMROM_UNROLL
      for (int c = 0; c < 2; ++c) {
        if (c >= columns) continue;
        MPMROM_UNROLL
        for (int i = 0; i < R; ++i) x[c][i] = rhs[c][i];
        dense::SerialCholeskySolveFixed<R>(L, x[c]);
        MPMROM_UNROLL
        for (int i = 0; i < R; ++i)
          if (!math::isfinite(x[c][i])) return flags | flag_not_finite;
      }
      return flags;
    }
    flags |= flag_ill_conditioned;
  }
  return flags | flag_singular;
}

// One row of the normal equations and its right-hand sides (velocity, position step) as a lane sums its share of
// the samples' rows: registers, reduced across the lanes in one pass.
struct NormalRow {
  real_t v[max_latent_dim + 2];
  KOKKOS_INLINE_FUNCTION NormalRow() {
    for (int c = 0; c < max_latent_dim + 2; ++c) v[c] = real_t(0);
  }
  KOKKOS_INLINE_FUNCTION NormalRow& operator+=(const NormalRow& other) {
    for (int c = 0; c < max_latent_dim + 2; ++c) v[c] += other.v[c];
    return *this;
  }
};

}  // namespace mpmrom::rom

namespace Kokkos {
template <>
struct reduction_identity<mpmrom::rom::NormalRow> {
  KOKKOS_FORCEINLINE_FUNCTION static mpmrom::rom::NormalRow sum() { return mpmrom::rom::NormalRow(); }
};
}  // namespace Kokkos

namespace mpmrom::rom {

template <class ExecutionSpace, class MemorySpace>
struct ProjectSamples {
  using member_type = typename Kokkos::TeamPolicy<ExecutionSpace>::member_type;
  using scratch_view = Kokkos::View<real_t*, typename ExecutionSpace::scratch_memory_space, Kokkos::MemoryUnmanaged>;
  static constexpr int lda = max_latent_dim;

  int latent_dim;
  Kokkos::View<const real_t*, MemorySpace> weight;   // (samples): the samples' masses
  BatchJacobians<MemorySpace> sample_J;              // (rollouts, samples, 3, r) at the evaluated state
  BatchVectors<MemorySpace> sample_velocity;         // (rollouts, samples, 3) from G2P
  BatchVectors<MemorySpace> sample_x;                // (rollouts, samples, 3) at t_n
  BatchVectors<MemorySpace> evaluated_x;             // (rollouts, samples, 3) at the evaluated state (positions pass)
  BatchMatrix<MemorySpace> xhat, xhatdot;            // at t_n
  BatchMatrix<MemorySpace> xhat_next, xhatdot_next;  // in: the evaluated state (later passes); out: the new state
  ProjectionGuard guard;
  real_t rate_damping;  // Tikhonov weight toward xhatdot_n, relative to the mean eigenvalue of J^T W J
  real_t dt;
  bool first_pass;         // J at xhat(t_n); a rollout that stops in a later pass keeps the state of the pass before
  bool project_positions;  // also the Gauss-Newton step on the samples' positions (a later pass of "position")
  Kokkos::View<int*, MemorySpace> flags;
  Kokkos::View<real_t*, MemorySpace> max_condition;   // largest estimate over the rollout's steps
  Kokkos::View<int*, MemorySpace> regularized_steps;  // steps that needed regularisation
  // The Galerkin step's (galerkin.hpp): each sample's reduced force per unit mass, (rollouts, samples * r), whose
  // weighted sum times dt joins the velocity's right-hand side; empty: none.
  BatchMatrix<MemorySpace> sample_force = {};
  Kokkos::View<const real_t*, MemorySpace> force_weight = {};  // (samples): the forces' weights (the Galerkin step's)
  // The velocity scheme's position update xhat + drift * xhatdot_next: dt, or half of it where xhat is already half a
  // step on (the Galerkin step's leapfrog); 0: dt.
  real_t drift = 0;

  static std::size_t scratch_bytes() { return scratch_view::shmem_size(lda * lda + 2 * lda); }

  KOKKOS_INLINE_FUNCTION void operator()(const member_type& team) const {
    const int b = team.league_rank();
    if (flags(b) & fatal_flags) {
      Kokkos::single(Kokkos::PerTeam(team), [&]() { hold(b); });
      return;
    }
    scratch_view shared(team.team_scratch(0), lda * lda + 2 * lda);
    assemble(team, b, shared.data());
    team.team_barrier();
    Kokkos::single(Kokkos::PerTeam(team), [&]() { solve(b, shared.data()); });
  }

  // One rollout a thread (large GPU batches, where a team of r x 32 per rollout keeps few teams resident for its
  // registers): the samples' rows summed in order, as a team of one thread of one lane sums them, then solve.
  KOKKOS_INLINE_FUNCTION void operator()(const int b) const {
    if (flags(b) & fatal_flags) {
      hold(b);
      return;
    }
    with_latent_dim(latent_dim, [&](auto R) { this->template sum_and_solve<decltype(R)::value>(b); });
  }

  template <int R>
  KOKKOS_INLINE_FUNCTION void sum_and_solve(const int b) const {
    const int rows = 3 * int(sample_J.extent(1));
    const bool forces = sample_force.extent(0) > 0;
    real_t A[R][R] = {}, rhs[2][R] = {};  // J^T W J, then the two right-hand sides
    for (int row = 0; row < rows; ++row) {
      const int s = row / 3, k = row % 3;
      const real_t* Jrow = &sample_J(b, s, k, 0);
      const real_t v = sample_velocity(b, s, k);
      const real_t miss = project_positions ? sample_x(b, s, k) + dt * v - evaluated_x(b, s, k) : real_t(0);
      MPMROM_UNROLL
      for (int i = 0; i < R; ++i) {
        const real_t wJ = weight(s) * Jrow[i];
        MPMROM_UNROLL
        for (int j = 0; j < R; ++j) A[i][j] += wJ * Jrow[j];
        rhs[0][i] += wJ * v;
        if (forces && k == 0) rhs[0][i] += force_weight(s) * dt * sample_force(b, s * R + i);
        rhs[1][i] += wJ * miss;
      }
    }
    solve_fixed<R>(b, A, rhs);
  }

  // Public for nvcc: the team lambdas below may not live in private member functions.
  KOKKOS_INLINE_FUNCTION void hold(int b) const {
    if (!first_pass) return;
    for (int q = 0; q < latent_dim; ++q) {
      xhat_next(b, q) = xhat(b, q);
      xhatdot_next(b, q) = xhatdot(b, q);
    }
  }

  // J^T W J (row-major in shared), J^T W v (after it) and, for a positions pass, J^T W (x_n + dt v - x) (after that):
  // row i of each by one team thread, the samples' rows across its lanes.
  KOKKOS_INLINE_FUNCTION void assemble(const member_type& team, int b, real_t* shared) const {
    const int r = latent_dim;
    const int rows = 3 * int(sample_J.extent(1));
    // A lane takes rows_a_lane consecutive rows at a time, unrolled, so that their loads go out together (a lane's
    // rows one after another waited on each row's loads in turn).
    constexpr int rows_a_lane = 4;
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, r), [&](const int i) {
      NormalRow sums;
      Kokkos::parallel_reduce(
          Kokkos::ThreadVectorRange(team, (rows + rows_a_lane - 1) / rows_a_lane),
          [&](const int chunk, NormalRow& partial) {
            MPMROM_UNROLL
            for (int j = 0; j < rows_a_lane; ++j)
              if (chunk * rows_a_lane + j < rows) add_row(b, i, chunk * rows_a_lane + j, partial);
          },
          sums);
      Kokkos::single(Kokkos::PerThread(team), [&]() {
        for (int j = 0; j < max_latent_dim; ++j)
          if (j < r) shared[i * lda + j] = sums.v[j];
        shared[lda * lda + i] = sums.v[max_latent_dim];
        shared[lda * lda + lda + i] = sums.v[max_latent_dim + 1];
      });
    });
  }

  // One sample row's share of row i of J^T W J and of the right-hand sides.
  KOKKOS_INLINE_FUNCTION void add_row(int b, int i, int row, NormalRow& partial) const {
    const int r = latent_dim, s = row / 3, k = row % 3;
    const real_t* Jrow = &sample_J(b, s, k, 0);
    const real_t wJ = weight(s) * Jrow[i];
    for (int j = 0; j < max_latent_dim; ++j)
      if (j < r) partial.v[j] += wJ * Jrow[j];
    const real_t v = sample_velocity(b, s, k);
    partial.v[max_latent_dim] += wJ * v;
    if (sample_force.extent(0) > 0 && k == 0)
      partial.v[max_latent_dim] += force_weight(s) * dt * sample_force(b, s * r + i);
    if (project_positions) partial.v[max_latent_dim + 1] += wJ * (sample_x(b, s, k) + dt * v - evaluated_x(b, s, k));
  }

  // The sums assemble left in scratch (J^T W J row-major, lda apart, then the two right-hand sides), solved. One
  // thread.
  KOKKOS_INLINE_FUNCTION void solve(int b, const real_t* shared) const {
    with_latent_dim(latent_dim, [&](auto R) {
      constexpr int r = decltype(R)::value;
      real_t A[r][r], rhs[2][r];
      MPMROM_UNROLL
      for (int i = 0; i < r; ++i) {
        MPMROM_UNROLL
        for (int j = 0; j < r; ++j) A[i][j] = shared[i * lda + j];
        rhs[0][i] = shared[lda * lda + i];
        rhs[1][i] = shared[lda * lda + lda + i];
      }
      this->template solve_fixed<r>(b, A, rhs);
    });
  }

  // Tikhonov term, guarded solve, detectors and the new state, all in registers. One thread.
  template <int R>
  KOKKOS_INLINE_FUNCTION void solve_fixed(int b, real_t (&A)[R][R], real_t (&rhs)[2][R]) const {
    if (rate_damping > real_t(0)) {
      real_t trace = 0;
      MPMROM_UNROLL
      for (int i = 0; i < R; ++i) trace += A[i][i];
      const real_t lambda = rate_damping * trace / real_t(R);
      MPMROM_UNROLL
      for (int i = 0; i < R; ++i) {
        A[i][i] += lambda;
        rhs[0][i] += lambda * xhatdot(b, i);
      }
    }
    real_t solution[2][R] = {};  // the rate, then the position step
    real_t condition = 0;
    const int raised = SerialGuardedSolve<R>(A, rhs, guard, solution, condition, project_positions ? 2 : 1);
    if (condition > max_condition(b)) max_condition(b) = condition;
    if (raised & flag_ill_conditioned) ++regularized_steps(b);
    if (raised) flags(b) |= raised;
    if (raised & fatal_flags) {
      hold(b);
      return;
    }
    if (guard.max_latent_speed > real_t(0)) {
      real_t speed2 = 0;
      MPMROM_UNROLL
      for (int q = 0; q < R; ++q) speed2 += solution[0][q] * solution[0][q];
      if (speed2 > guard.max_latent_speed * guard.max_latent_speed) {
        flags(b) |= flag_energy;
        hold(b);
        return;
      }
    }
    const real_t step = drift > real_t(0) ? drift : dt;
    MPMROM_UNROLL
    for (int q = 0; q < R; ++q) {
      xhatdot_next(b, q) = solution[0][q];
      xhat_next(b, q) = project_positions ? xhat_next(b, q) + solution[1][q] : xhat(b, q) + step * solution[0][q];
    }
  }
};

}  // namespace mpmrom::rom
