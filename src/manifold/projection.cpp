// A trained manifold applied to new snapshots (manifold/trainer.hpp): the codes that fit them best, and the errors of
// the reconstruction. Network evaluations only: the training kernels stay in trainer.cpp.
#include "manifold/trainer.hpp"

#include <Kokkos_Core.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "core/math/cholesky.hpp"
#include "manifold/detail/rate_stencil.hpp"
#include "manifold/device_data.hpp"
#include "manifold/nn/mlp_batch.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom {
namespace {

using ExecutionSpace = Kokkos::DefaultExecutionSpace;
using T = real_t;
using MemorySpace = impl::DeviceMemory;
using Vector = impl::DeviceVector;
using Matrix = impl::DeviceMatrix;
using Cube = impl::DeviceCube;
using Quad = impl::DeviceQuad;
using impl::device_mlp;
using impl::download;
using impl::upload;

// Each frame's start: the training code that fits it best on a subset of points.
std::vector<double> closest_training_codes(const Model& model, const Snapshot& run,
                                           const nn::Mlp<T, MemorySpace>& mlp) {
  const int r = model.latent_dim;
  const int P = int(run.num_points), frames = int(run.num_frames);
  std::vector<int> subset;
  for (int p = 0; p < P; p += std::max(1, P / 256)) subset.push_back(p);
  std::vector<double> X_subset;
  for (const int p : subset) X_subset.insert(X_subset.end(), run.X.begin() + 3 * p, run.X.begin() + 3 * p + 3);
  const int num_train = int(model.num_codes());
  const Matrix train_codes = upload<Matrix>("mpmrom::project::train_codes", model.codes, num_train, r);
  Cube g_subset("mpmrom::project::g_subset", num_train, subset.size(), 3);
  nn::evaluate(ExecutionSpace(), mlp, nn::PointsView<T, MemorySpace>(upload<Matrix>("X", X_subset, subset.size(), 3)),
               nn::CodesView<T, MemorySpace>(train_codes), g_subset);
  const auto g_train = download(g_subset);
  std::vector<double> codes(std::size_t(frames) * r);
  for (int f = 0; f < frames; ++f) {
    double best = INFINITY;
    for (int c = 0; c < num_train; ++c) {
      double misfit = 0;
      for (std::size_t i = 0; i < subset.size(); ++i)
        for (int d = 0; d < 3; ++d) {
          const double e = g_train[(c * subset.size() + i) * 3 + d] - run.x[(std::size_t(f) * P + subset[i]) * 3 + d];
          misfit += e * e;
        }
      if (misfit < best) {
        best = misfit;
        std::copy(model.codes.begin() + c * r, model.codes.begin() + (c + 1) * r, codes.begin() + f * r);
      }
    }
  }
  return codes;
}

// The Levenberg-Marquardt sums of every frame, on the device: entry e of frame f summed over one block of points
// (upper triangle of J^T J, then J^T (g - x), then |g - x|^2), each thread one (frame, block, entry), so that the sums
// do not depend on the backend's scheduling; the host adds the blocks in order. With J empty, the misfit alone.
using Positions = Kokkos::View<double***, Kokkos::LayoutRight, MemorySpace>;  // the run's, in double whatever T

struct MisfitSums {
  static constexpr int blocks = 64;
  Cube g;
  Positions x;
  Quad J;
  Kokkos::View<double***, Kokkos::LayoutRight, MemorySpace> partial;  // (frames, blocks, entries)
  int P, r, entries;

  static int entries_of(int r) { return r * (r + 1) / 2 + r + 1; }

  KOKKOS_FUNCTION void operator()(const long item) const {
    const int e = int(item % entries), block = int(item / entries % blocks), f = int(item / entries / blocks);
    const int begin = int(long(P) * block / blocks), end = int(long(P) * (block + 1) / blocks);
    int a = 0, b = e;  // (a, b) of an upper-triangle entry, row by row
    while (a < r && b >= r - a) b -= r - a++;
    b += a;
    double sum = 0;
    for (int p = begin; p < end; ++p)
      for (int k = 0; k < 3; ++k) {
        if (a < r) {  // J^T J's entries read no positions
          sum += double(J(f, p, k, a)) * double(J(f, p, k, b));
          continue;
        }
        const double residual = double(g(f, p, k)) - x(f, p, k);
        sum += e < entries - 1 ? double(J(f, p, k, e - (entries - 1 - r))) * residual : residual * residual;
      }
    partial(f, block, e) = sum;
  }
};

// Per frame: J^T J (r x r, full), J^T (g - x) and the misfit |g - x|^2 of the positions g decoded at the codes.
struct NormalEquations {
  std::vector<double> JtJ, Jtr, cost;
};

NormalEquations misfit_sums(const Cube& g, const Quad& J, const Positions& x, int frames, int P, int r) {
  const bool with_jacobian = J.extent(0) > 0;
  const int entries = with_jacobian ? MisfitSums::entries_of(r) : 1;
  MisfitSums sums{g, x, J, {}, P, with_jacobian ? r : 0, entries};
  sums.partial = decltype(sums.partial)("mpmrom::project::partial", frames, MisfitSums::blocks, entries);
  Kokkos::parallel_for("mpmrom::project::misfit_sums",
                       Kokkos::RangePolicy<ExecutionSpace>(0, long(frames) * MisfitSums::blocks * entries), sums);
  const auto partial = download(sums.partial);
  NormalEquations out{std::vector<double>(std::size_t(frames) * r * r), std::vector<double>(std::size_t(frames) * r),
                      std::vector<double>(frames)};
  for (int f = 0; f < frames; ++f)
    for (int block = 0; block < MisfitSums::blocks; ++block) {
      const double* row = &partial[(std::size_t(f) * MisfitSums::blocks + block) * entries];
      out.cost[f] += row[entries - 1];
      if (!with_jacobian) continue;
      for (int a = 0, e = 0; a < r; ++a)
        for (int b = a; b < r; ++b, ++e) out.JtJ[(std::size_t(f) * r + a) * r + b] += row[e];
      for (int a = 0; a < r; ++a) out.Jtr[std::size_t(f) * r + a] += row[entries - 1 - r + a];
    }
  for (int f = 0; f < frames && with_jacobian; ++f)
    for (int a = 0; a < r; ++a)
      for (int b = 0; b < a; ++b) out.JtJ[(std::size_t(f) * r + a) * r + b] = out.JtJ[(std::size_t(f) * r + b) * r + a];
  return out;
}

// Frame f's Levenberg-Marquardt step, (J^T J + mu diag(J^T J)) delta = -J^T (g - x), added to its code in trial;
// false, with trial unchanged, where the damped matrix is not positive definite.
bool add_damped_step(const NormalEquations& normal, int f, int r, double mu, std::vector<double>& trial) {
  const double* JtJ = &normal.JtJ[std::size_t(f) * r * r];
  std::vector<double> A(JtJ, JtJ + r * r), delta(r);
  double trace = 0;
  for (int a = 0; a < r; ++a) trace += JtJ[a * r + a];
  for (int a = 0; a < r; ++a) A[a * r + a] += mu * JtJ[a * r + a] + 1e-14 * trace;
  for (int a = 0; a < r; ++a) delta[a] = -normal.Jtr[std::size_t(f) * r + a];
  if (!dense::SerialCholesky(A.data(), r, r)) return false;
  dense::SerialCholeskySolve(A.data(), r, r, delta.data());
  for (int a = 0; a < r; ++a) trial[f * r + a] += delta[a];
  return true;
}

}  // namespace

std::vector<double> project_codes(const Model& model, const Snapshot& run) {
  const int r = model.latent_dim;
  const int P = int(run.num_points), frames = int(run.num_frames);
  if (run.num_points != model.num_points())
    throw std::runtime_error("run has " + std::to_string(run.num_points) + " points, the model was trained on " +
                             std::to_string(model.num_points()));
  const nn::MlpLayout layout = model.layout();
  const Vector weights = upload<Vector>("mpmrom::project::weights", model.weights, layout.num_params);
  const auto mlp = device_mlp(model, weights);
  const ExecutionSpace space;
  const Matrix X = upload<Matrix>("mpmrom::project::X", run.X, P, 3);
  std::vector<double> codes = closest_training_codes(model, run, mlp);

  // Levenberg-Marquardt, every frame at once.
  Cube g("mpmrom::project::g", frames, P, 3), velocity;
  Quad F("mpmrom::project::F", frames, P, 3, 3), J("mpmrom::project::J", frames, P, 3, r);
  Matrix device_codes("mpmrom::project::codes", frames, r);
  auto host_codes = Kokkos::create_mirror_view(device_codes);
  const auto set_codes = [&](const std::vector<double>& values) {
    for (std::size_t i = 0; i < values.size(); ++i) host_codes.data()[i] = T(values[i]);
    Kokkos::deep_copy(device_codes, host_codes);
  };
  const Positions x = upload<Positions>("mpmrom::project::x", run.x, frames, P, 3);
  std::vector<double> mu(frames, 1e-3), cost(frames);
  std::vector<bool> converged(frames, false);
  for (int iteration = 0; iteration < 100; ++iteration) {
    set_codes(codes);
    nn::evaluate_with_jacobians(space, mlp, nn::PointsView<T, MemorySpace>(X),
                                nn::CodesView<T, MemorySpace>(device_codes), nn::CodesView<T, MemorySpace>(), g, F, J,
                                velocity);
    const NormalEquations normal = misfit_sums(g, J, x, frames, P, r);
    std::vector<double> trial = codes;
    for (int f = 0; f < frames; ++f) {
      cost[f] = normal.cost[f];
      if (converged[f]) continue;
      if (!add_damped_step(normal, f, r, mu[f], trial)) mu[f] *= 10;
    }
    // Accept each frame's step if it lowers that frame's misfit, else damp more.
    set_codes(trial);
    nn::evaluate(space, mlp, nn::PointsView<T, MemorySpace>(X), nn::CodesView<T, MemorySpace>(device_codes), g);
    const std::vector<double> trial_cost = misfit_sums(g, Quad(), x, frames, P, r).cost;
    bool all_done = true;
    for (int f = 0; f < frames; ++f) {
      if (converged[f]) continue;
      const double new_cost = trial_cost[f];
      if (new_cost < cost[f]) {
        // converged once a step gains less than a part in 1e6 of the misfit (rounding level in float)
        if (cost[f] - new_cost <= 1e-6 * cost[f]) converged[f] = true;
        std::copy(trial.begin() + f * r, trial.begin() + (f + 1) * r, codes.begin() + f * r);
        mu[f] = std::max(mu[f] / 3, 1e-9);
      } else {
        mu[f] *= 5;
        if (mu[f] > 1e8) converged[f] = true;  // no descent left at any damping: a local minimum
      }
      all_done = all_done && converged[f];
    }
    if (all_done) break;
  }
  return codes;
}

namespace {

// sqrt(misfit / total), as ErrorAccumulator reports a ratio: 0 for no motion and no misfit, else infinity.
double relative_error(double misfit, double total) {
  return total > 0 ? std::sqrt(misfit / total) : (misfit > 0 ? INFINITY : 0.0);
}

}  // namespace

double VelocityByFrame::tangent_velocity_error() const {
  return relative_error(std::accumulate(tangent_misfit.begin(), tangent_misfit.end(), 0.0),
                        std::accumulate(norm.begin(), norm.end(), 0.0));
}

nlohmann::json VelocityByFrame::frames_json() const {
  nlohmann::json out = nlohmann::json::array();
  for (std::size_t f = 0; f < time.size(); ++f)
    out.push_back({{"time", time[f]},
                   {"velocity_error", relative_error(rate_misfit[f], norm[f])},
                   {"tangent_velocity_error", relative_error(tangent_misfit[f], norm[f])}});
  return out;
}

namespace {

// Per frame, the velocity misfits of the rates and of the tangent space's best fit, from the sums of misfit_sums
// taken with the decoded velocities J rate in place of g and the run's velocities in place of x: with b = J^T (J rate
// - v) and A = J^T J, min over rates a of |J a - v|^2 is |J rate - v|^2 - b^T A^-1 b.
VelocityByFrame velocity_by_frame(const Snapshot& run, const Cube& velocity, const Quad& J, int r) {
  const int P = int(run.num_points), frames = int(run.num_frames);
  const Positions v = upload<Positions>("mpmrom::errors::v_run", run.v, frames, P, 3);
  const NormalEquations sums = misfit_sums(velocity, J, v, frames, P, r);
  VelocityByFrame out{run.time, sums.cost, sums.cost, std::vector<double>(frames)};
  for (int f = 0; f < frames; ++f) {
    for (std::size_t i = std::size_t(f) * P * 3; i < std::size_t(f + 1) * P * 3; ++i)
      out.norm[f] += run.v[i] * run.v[i];
    std::vector<double> A(&sums.JtJ[std::size_t(f) * r * r], &sums.JtJ[std::size_t(f + 1) * r * r]);
    std::vector<double> correction(&sums.Jtr[std::size_t(f) * r], &sums.Jtr[std::size_t(f + 1) * r]);
    if (!dense::SerialCholesky(A.data(), r, r)) continue;  // a degenerate tangent space: the rates' misfit stands
    dense::SerialCholeskySolve(A.data(), r, r, correction.data());
    double reduction = 0;
    for (int a = 0; a < r; ++a) reduction += sums.Jtr[std::size_t(f) * r + a] * correction[a];
    out.tangent_misfit[f] = std::max(sums.cost[f] - reduction, 0.0);  // cancellation may leave a rounding below 0
  }
  return out;
}

}  // namespace

ReconstructionErrors reconstruction_errors(const Model& model, const Snapshot& run, const std::vector<double>& codes,
                                           const std::vector<int>& points) {
  const int r = model.latent_dim;
  const int P = int(run.num_points), frames = int(run.num_frames);
  if (codes.size() != std::size_t(frames) * r) throw std::invalid_argument("one code per frame is needed");
  impl::RateStencil stencil;
  stencil.add_run(run.time, 0, impl::starts_at_rest(run));
  const auto rates = stencil.rates(codes, r);
  const nn::MlpLayout layout = model.layout();
  const Vector weights = upload<Vector>("mpmrom::errors::weights", model.weights, layout.num_params);
  const auto mlp = device_mlp(model, weights);
  Cube g("mpmrom::errors::g", frames, P, 3), velocity("mpmrom::errors::v", frames, P, 3);
  Quad F("mpmrom::errors::F", frames, P, 3, 3), J("mpmrom::errors::J", frames, P, 3, r);
  nn::evaluate_with_jacobians(ExecutionSpace(), mlp, nn::PointsView<T, MemorySpace>(upload<Matrix>("X", run.X, P, 3)),
                              nn::CodesView<T, MemorySpace>(upload<Matrix>("codes", codes, frames, r)),
                              nn::CodesView<T, MemorySpace>(upload<Matrix>("rates", rates, frames, r)), g, F, J,
                              velocity);
  const auto g_host = download(g), F_host = download(F), v_host = download(velocity);
  double centroid[3] = {0, 0, 0};
  for (int p = 0; p < P; ++p)
    for (int d = 0; d < 3; ++d) centroid[d] += run.X[3 * p + d] / P;
  std::vector<int> all;
  if (points.empty()) {
    all.resize(P);
    std::iota(all.begin(), all.end(), 0);
  }
  ReconstructionErrors out;
  for (int f = 0; f < frames; ++f)
    for (const int p : points.empty() ? all : points) {
      const std::size_t i = std::size_t(f) * P + p;
      out.errors.add(centroid, &run.X[3 * p], &run.x[3 * i], &g_host[3 * i], &run.v[3 * i], &v_host[3 * i],
                     &run.F[9 * i], &F_host[9 * i]);
    }
  if (points.empty()) out.velocity = velocity_by_frame(run, velocity, J, r);
  return out;
}

}  // namespace mpmrom
