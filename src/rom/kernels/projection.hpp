// The velocity projection (Algorithm 1 step 6, Algorithm 2 step 8): per rollout, xhatdot minimises
// sum_s |J_s xhatdot - v_s|^2 over the sample points (J_s = dg/dxhat at X_s), through the normal equations
// (J^T J) xhatdot = J^T v, and the next state is xhat + dt xhatdot. J_s is evaluated at the latent state the driver
// passes: the paper's xhat(t_n), or the trial next state when the driver iterates (docs/rom.md says why).
//
// Parallelism: one team per rollout; the team's threads take the entries of J^T J and J^T v, each a
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

// Solves (A + 0) x = rhs for the r x r SPD matrix A (row-major, lda = max_latent_dim) with the guard above. Returns
// the flags raised; condition receives the estimate of the system actually solved. Parallelism contract: one thread.
KOKKOS_INLINE_FUNCTION int SerialGuardedSolve(const real_t* A, const real_t* rhs, int r, const ProjectionGuard& guard,
                                              real_t* x, real_t& condition) {
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
      for (int i = 0; i < r; ++i) x[i] = rhs[i];
      dense::SerialCholeskySolve(L, r, lda, x);
      for (int i = 0; i < r; ++i)
        if (!math::isfinite(x[i])) return flags | flag_not_finite;
      return flags;
    }
    flags |= flag_ill_conditioned;
  }
  return flags | flag_singular;
}

template <class ExecutionSpace, class MemorySpace>
struct ProjectVelocities {
  using member_type = typename Kokkos::TeamPolicy<ExecutionSpace>::member_type;
  using scratch_view = Kokkos::View<real_t*, typename ExecutionSpace::scratch_memory_space, Kokkos::MemoryUnmanaged>;

  int latent_dim;
  BatchJacobians<MemorySpace> sample_J;              // (rollouts, samples, 3, r) at xhat(t_n)
  BatchVectors<MemorySpace> sample_velocity;         // (rollouts, samples, 3) from G2P
  BatchMatrix<MemorySpace> xhat, xhatdot;            // at t_n
  BatchMatrix<MemorySpace> xhat_next, xhatdot_next;  // the new state; a rollout that has stopped keeps the old one
  ProjectionGuard guard;
  real_t dt;
  bool first_pass;  // a rollout that stops in a later pass keeps the state of the pass before
  Kokkos::View<int*, MemorySpace> flags;
  Kokkos::View<real_t*, MemorySpace> max_condition;   // largest estimate over the rollout's steps
  Kokkos::View<int*, MemorySpace> regularized_steps;  // steps that needed regularisation

  static std::size_t scratch_bytes(int r) { return scratch_view::shmem_size(r * max_latent_dim + r); }

  KOKKOS_INLINE_FUNCTION void operator()(const member_type& team) const {
    const int b = team.league_rank();
    const int r = latent_dim;
    const auto hold = [&]() {
      if (!first_pass) return;
      for (int q = 0; q < r; ++q) {
        xhat_next(b, q) = xhat(b, q);
        xhatdot_next(b, q) = xhatdot(b, q);
      }
    };
    if (flags(b) & fatal_flags) {
      Kokkos::single(Kokkos::PerTeam(team), hold);
      return;
    }
    const int rows = 3 * int(sample_J.extent(1));
    scratch_view shared(team.team_scratch(0), r * max_latent_dim + r);
    const int matrix_entries = r * (r + 1) / 2;
    Kokkos::parallel_for(Kokkos::TeamThreadRange(team, matrix_entries + r), [&](const int entry) {
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
              partial += Jrow[i] * Jrow[j];
            },
            sum);
        Kokkos::single(Kokkos::PerThread(team), [&]() {
          shared(i * max_latent_dim + j) = sum;
          shared(j * max_latent_dim + i) = sum;
        });
      } else {
        const int i = entry - matrix_entries;
        Kokkos::parallel_reduce(
            Kokkos::ThreadVectorRange(team, rows),
            [&](const int row, real_t& partial) {
              partial += sample_J(b, row / 3, row % 3, i) * sample_velocity(b, row / 3, row % 3);
            },
            sum);
        Kokkos::single(Kokkos::PerThread(team), [&]() { shared(r * max_latent_dim + i) = sum; });
      }
    });
    team.team_barrier();
    Kokkos::single(Kokkos::PerTeam(team), [&]() {
      real_t rate[max_latent_dim];
      real_t condition = 0;
      const int raised =
          SerialGuardedSolve(shared.data(), shared.data() + r * max_latent_dim, r, guard, rate, condition);
      if (condition > max_condition(b)) max_condition(b) = condition;
      if (raised & flag_ill_conditioned) ++regularized_steps(b);
      if (raised) flags(b) |= raised;
      if (raised & fatal_flags) {
        hold();
        return;
      }
      if (guard.max_latent_speed > real_t(0)) {
        real_t speed2 = 0;
        for (int q = 0; q < r; ++q) speed2 += rate[q] * rate[q];
        if (speed2 > guard.max_latent_speed * guard.max_latent_speed) {
          flags(b) |= flag_energy;
          hold();
          return;
        }
      }
      for (int q = 0; q < r; ++q) {
        xhatdot_next(b, q) = rate[q];
        xhat_next(b, q) = xhat(b, q) + dt * rate[q];
      }
    });
  }
};

}  // namespace mpmrom::rom
