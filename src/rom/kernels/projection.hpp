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
// Parallelism: one team per rollout; the team's threads take the entries of J^T W J and the right-hand sides, each a
// parallel_reduce over the samples' rows across vector lanes; one thread then factors and solves the r x r system
// (core/math/cholesky.hpp). Guard: the condition number is estimated from the Cholesky factor as (max L_ii / min
// L_ii)^2 (a lower bound of cond_2); above max_condition, or when the factorisation fails, the system is regularised
// with mu I, mu = regularization * trace / r, and the rollout flagged; if that fails too, or the solution is not
// finite, the rollout is flagged and its state left as it was, never set to NaN. With regularisation off, an
// ill-conditioned system stops the rollout instead (flag_ill_posed). A projected latent speed |xhatdot| above
// max_latent_speed stops it too (flag_energy): the reduced kinetic energy has left every bound the training motion
// sets.
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

// Solves A x = rhs for the r x r SPD matrix A (row-major, lda = max_latent_dim) and `columns` right-hand sides
// (rhs and x: columns vectors max_latent_dim apart) with the guard above. Returns the flags raised; condition
// receives the estimate of the system actually solved. Parallelism contract: one thread.

KOKKOS_INLINE_FUNCTION int SerialGuardedSolve(const real_t* A, const real_t* rhs, int r, const ProjectionGuard& guard,
                                              real_t* x, real_t& condition, int columns = 1) {
  constexpr int lda = max_latent_dim;
  real_t L[max_latent_dim * max_latent_dim];
  real_t trace = 0;
  for (int i = 0; i < r; ++i) trace += A[i * lda + i];
  int flags = 0;
  for (int attempt = 0; attempt < 2; ++attempt) {
    const real_t mu = attempt == 0 ? real_t(0) : guard.regularization * trace / real_t(r);
    for (int i = 0; i < r; ++i)
      for (int j = 0; j < r; ++j) L[i * lda + j] = A[i * lda + j] + (i == j ? mu : real_t(0));
    bool ok = dense::SerialCholesky(L, r, lda);
    if (ok) {
      real_t lo = L[0], hi = L[0];
      for (int i = 1; i < r; ++i) {
        lo = math::min(lo, L[i * lda + i]);
        hi = math::max(hi, L[i * lda + i]);
      }
      condition = (hi / lo) * (hi / lo);
      ok = attempt == 1 || condition <= guard.max_condition;
    }
    if (!ok && !guard.regularize) return flags | flag_ill_conditioned | flag_ill_posed;
    if (ok) {
      for (int c = 0; c < columns; ++c) {
        real_t* column = x + c * lda;
        for (int i = 0; i < r; ++i) column[i] = rhs[c * lda + i];
        dense::SerialCholeskySolve(L, r, lda, column);
        for (int i = 0; i < r; ++i)
          if (!math::isfinite(column[i])) return flags | flag_not_finite;
      }
      return flags;
    }
    flags |= flag_ill_conditioned;
  }
  return flags | flag_singular;
}

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

  // Public for nvcc: the team lambdas below may not live in private member functions.
  KOKKOS_INLINE_FUNCTION void hold(int b) const {
    if (!first_pass) return;
    for (int q = 0; q < latent_dim; ++q) {
      xhat_next(b, q) = xhat(b, q);
      xhatdot_next(b, q) = xhatdot(b, q);
    }
  }

  // J^T W J (row-major in shared), J^T W v (after it) and, for a positions pass, J^T W (x_n + dt v - x) (after that).
  KOKKOS_INLINE_FUNCTION void assemble(const member_type& team, int b, real_t* shared) const {
    const int r = latent_dim;
    const int rows = 3 * int(sample_J.extent(1));
    const int matrix_entries = r * (r + 1) / 2;
    const int entries = matrix_entries + (project_positions ? 2 * r : r);
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, entries), [&](const int entry) {
      real_t sum = 0;
      if (entry < matrix_entries) {
        int i = 0, offset = entry;  // entry -> (i, j), j >= i, row by row of the upper triangle
        while (offset >= r - i) {
          offset -= r - i;
          ++i;
        }
        const int j = i + offset;
        Kokkos::parallel_reduce(
            Kokkos::ThreadVectorRange(team, rows),
            [&](const int row, real_t& partial) {
              const real_t* Jrow = &sample_J(b, row / 3, row % 3, 0);
              partial += weight(row / 3) * Jrow[i] * Jrow[j];
            },
            sum);
        Kokkos::single(Kokkos::PerThread(team), [&]() {
          shared[i * lda + j] = sum;
          shared[j * lda + i] = sum;
        });
      } else {
        const int column = (entry - matrix_entries) / r, i = (entry - matrix_entries) % r;
        Kokkos::parallel_reduce(
            Kokkos::ThreadVectorRange(team, rows),
            [&](const int row, real_t& partial) {
              const int s = row / 3, k = row % 3;
              const real_t v = sample_velocity(b, s, k);
              const real_t target = column == 0 ? v : sample_x(b, s, k) + dt * v - evaluated_x(b, s, k);
              partial += weight(s) * sample_J(b, s, k, i) * target;
              if (column == 0 && k == 0 && sample_force.extent(0) > 0)
                partial += force_weight(s) * dt * sample_force(b, s * r + i);
            },
            sum);
        Kokkos::single(Kokkos::PerThread(team), [&]() { shared[lda * lda + column * lda + i] = sum; });
      }
    });
  }

  // Tikhonov term, guarded solve, detectors and the new state. One thread.
  KOKKOS_INLINE_FUNCTION void solve(int b, real_t* shared) const {
    const int r = latent_dim;
    real_t* rhs = shared + lda * lda;
    if (rate_damping > real_t(0)) {
      real_t trace = 0;
      for (int i = 0; i < r; ++i) trace += shared[i * lda + i];
      const real_t lambda = rate_damping * trace / real_t(r);
      for (int i = 0; i < r; ++i) {
        shared[i * lda + i] += lambda;
        rhs[i] += lambda * xhatdot(b, i);
      }
    }
    real_t solution[2 * lda];  // the rate, then the position step
    real_t condition = 0;
    const int raised = SerialGuardedSolve(shared, rhs, r, guard, solution, condition, project_positions ? 2 : 1);
    if (condition > max_condition(b)) max_condition(b) = condition;
    if (raised & flag_ill_conditioned) ++regularized_steps(b);
    if (raised) flags(b) |= raised;
    if (raised & fatal_flags) {
      hold(b);
      return;
    }
    if (guard.max_latent_speed > real_t(0)) {
      real_t speed2 = 0;
      for (int q = 0; q < r; ++q) speed2 += solution[q] * solution[q];
      if (speed2 > guard.max_latent_speed * guard.max_latent_speed) {
        flags(b) |= flag_energy;
        hold(b);
        return;
      }
    }
    const real_t step = drift > real_t(0) ? drift : dt;
    for (int q = 0; q < r; ++q) {
      xhatdot_next(b, q) = solution[q];
      xhat_next(b, q) = project_positions ? xhat_next(b, q) + solution[lda + q] : xhat(b, q) + step * solution[q];
    }
  }
};

}  // namespace mpmrom::rom
