// The Galerkin step's highest frequency (detail/stable_step.hpp): its explicit step (symplectic Euler in the latent
// state) is stable for dt below 2 / omega, which the grid's CFL number says nothing about once the force is a few
// weighted samples'.
#include "rom/detail/stable_step.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include "core/math/symmetric_eigen.hpp"
#include "rom/detail/rollout_driver.hpp"
#include "rom/detail/snapshots.hpp"
#include "rom/kernels/projection.hpp"  // fatal_flags

namespace mpmrom {
namespace {

// Each rollout's weighted force sum_s wf_s q_s (rollouts, r) and, with mass non-null, its M (rollouts, r, r) after
// one probe from state.
void reduced_terms(impl::BatchStepperBase& stepper, const impl::BatchState& state, const std::vector<double>& w,
                   const std::vector<double>& wf, std::vector<double>& force, std::vector<double>* mass) {
  stepper.restore(state);
  stepper.probe_substep();
  const auto inputs = stepper.last_projection_inputs();
  const std::size_t B = std::size_t(stepper.rollouts()), r = std::size_t(stepper.latent_dim()), S = w.size();
  force.assign(B * r, 0.0);
  if (mass) mass->assign(B * r * r, 0.0);
  for (std::size_t b = 0; b < B; ++b)
    for (std::size_t s = 0; s < S; ++s) {
      for (std::size_t k = 0; k < r; ++k) force[b * r + k] += wf[s] * inputs.force[(b * S + s) * r + k];
      if (!mass) continue;
      const double* J = &inputs.J[(b * S + s) * 3 * r];
      for (std::size_t i = 0; i < r; ++i)
        for (std::size_t j = 0; j < r; ++j)
          for (std::size_t d = 0; d < 3; ++d) (*mass)[(b * r + i) * r + j] += w[s] * J[d * r + i] * J[d * r + j];
    }
}

}  // namespace

double impl::reduced_highest_frequency(const Model& model, const Scene& scene, const RomSettings& settings,
                                       const HyperReduction& reduction) {
  const std::size_t r = std::size_t(model.latent_dim), S = reduction.samples.size();
  std::vector<double> w(S), wf(S);
  for (std::size_t s = 0; s < S; ++s) {
    w[s] = reduction.weights.empty() ? model.mass[std::size_t(reduction.samples[s])] : reduction.weights[s];
    wf[s] = reduction.force_weights.empty() ? w[s] : reduction.force_weights[s];
  }
  std::vector<int> indices;
  const auto cases = trained_cases(model, scene, stable_step_runs, indices);
  RomSettings probing = settings;
  probing.end_time = 0;  // the training runs' horizon
  const auto stepper = create_stepper(model, scene.source_path, scene.design.names, cases, probing, reduction);
  // Central differences in each latent coordinate, a step of 1e-4 of the coordinate's spread over the training codes
  std::vector<double> h(r, 0.0);
  for (std::size_t k = 0; k < r; ++k) {
    double lo = INFINITY, hi = -INFINITY;
    for (std::size_t c = 0; c < model.num_codes(); ++c) {
      lo = std::min(lo, model.codes[c * r + k]);
      hi = std::max(hi, model.codes[c * r + k]);
    }
    h[k] = 1e-4 * (hi > lo ? hi - lo : 1.0);
  }
  const std::size_t B = cases.size();
  double omega2 = 0;
  BatchState state = stepper->state();
  std::vector<double> force, mass, plus, minus, K(r * r);
  // The snapshots' frames: each costs 2 r + 1 sub-steps of the batch
  for (const int f : inner_frames(stepper->frames(), max_state_frames)) {
    state.frame = f;
    training_state(model, indices, f, stepper->frames(), state.xhat, state.xhatdot);
    reduced_terms(*stepper, state, w, wf, force, &mass);
    std::vector<std::vector<double>> columns(r);  // d(force)/d(xhat_k), (rollouts, r) each
    for (std::size_t k = 0; k < r; ++k) {
      BatchState moved = state;
      for (std::size_t b = 0; b < B; ++b) moved.xhat[b * r + k] += h[k];
      reduced_terms(*stepper, moved, w, wf, plus, nullptr);
      for (std::size_t b = 0; b < B; ++b) moved.xhat[b * r + k] -= 2 * h[k];
      reduced_terms(*stepper, moved, w, wf, minus, nullptr);
      columns[k].resize(B * r);
      for (std::size_t i = 0; i < B * r; ++i) columns[k][i] = (plus[i] - minus[i]) / (2 * h[k]);
    }
    for (std::size_t b = 0; b < B; ++b) {
      if (stepper->flags(int(b)) & rom::fatal_flags) continue;
      for (std::size_t i = 0; i < r; ++i)
        for (std::size_t k = 0; k < r; ++k) K[i * r + k] = -columns[k][b * r + i];  // stiffness: minus the force's
      const std::vector<double> Mb(mass.begin() + std::ptrdiff_t(b * r * r),
                                   mass.begin() + std::ptrdiff_t((b + 1) * r * r));
      omega2 = std::max(omega2, dense::largest_generalised_eigenvalue(K, Mb, int(r)));
    }
  }
  return std::sqrt(omega2);
}

}  // namespace mpmrom
