// The deformation-map network (src/manifold/nn/): every Jacobian of the fused evaluation and every gradient of loss (7)
// against central finite differences, on every backend. The finite-difference checks run in double whatever the
// build's precision (the kernels are templates on the scalar type), so the tolerances stay tight; a separate check
// compares the float kernels with the double ones.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <random>
#include <utility>
#include <vector>

#include "backends.hpp"
#include "random_network.hpp"
#include "manifold/nn/mlp_batch.hpp"
#include "manifold/nn/mlp_block.hpp"
#include "manifold/nn/mlp_kinematics.hpp"
#include "manifold/nn/mlp_team.hpp"
#include "manifold/nn/mlp_train.hpp"

namespace {

using namespace mpmrom;
using mpmrom::test::BackendName;
using mpmrom::test::EnabledBackends;
using mpmrom::test::HostNetwork;
using mpmrom::test::random_network;

template <class T>
constexpr double epsilon_of() {
  return std::numeric_limits<T>::epsilon();
}

template <class T, class MemorySpace>
struct DeviceNetwork {
  nn::Mlp<T, MemorySpace> mlp;
  Kokkos::View<T*, MemorySpace> params;
};

template <class T, class MemorySpace>
DeviceNetwork<T, MemorySpace> to_device(const HostNetwork& net) {
  DeviceNetwork<T, MemorySpace> d;
  d.params = Kokkos::View<T*, MemorySpace>("params", net.params.size());
  auto host = Kokkos::create_mirror_view(d.params);
  for (std::size_t i = 0; i < net.params.size(); ++i) host(i) = T(net.params[i]);
  Kokkos::deep_copy(d.params, host);
  d.mlp.layout = net.layout;
  for (int k = 0; k < 3; ++k) {
    d.mlp.standardization.input_mean[k] = T(net.standardization.input_mean[k]);
    d.mlp.standardization.input_scale[k] = T(net.standardization.input_scale[k]);
    d.mlp.standardization.output_mean[k] = T(net.standardization.output_mean[k]);
    d.mlp.standardization.output_scale[k] = T(net.standardization.output_scale[k]);
  }
  d.mlp.params = d.params;
  return d;
}

template <class T, class MemorySpace>
Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace> device_matrix(const std::vector<double>& values, int rows,
                                                                  int cols) {
  Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace> view("matrix", rows, cols);
  auto host = Kokkos::create_mirror_view(view);
  for (int i = 0; i < rows; ++i)
    for (int j = 0; j < cols; ++j) host(i, j) = T(values[std::size_t(i) * cols + j]);
  Kokkos::deep_copy(view, host);
  return view;
}

std::vector<double> random_values(std::size_t n, double lo, double hi, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> dist(lo, hi);
  std::vector<double> v(n);
  for (auto& x : v) x = dist(rng);
  return v;
}

// g at every (code, point), on the host.
template <class ExecutionSpace>
std::vector<double> positions(const HostNetwork& net, const std::vector<double>& X, const std::vector<double>& codes) {
  using Mem = typename ExecutionSpace::memory_space;
  const int r = net.layout.latent_dim;
  const int P = int(X.size() / 3), B = int(codes.size() / r);
  auto d = to_device<double, Mem>(net);
  Kokkos::View<double***, Kokkos::LayoutRight, Mem> g("g", B, P, 3);
  nn::evaluate(ExecutionSpace(), d.mlp, nn::PointsView<double, Mem>(device_matrix<double, Mem>(X, P, 3)),
               nn::CodesView<double, Mem>(device_matrix<double, Mem>(codes, B, r)), g);
  auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), g);
  return std::vector<double>(host.data(), host.data() + host.size());
}

template <class ExecutionSpace>
void check_jacobians_against_finite_differences() {
  using Mem = typename ExecutionSpace::memory_space;
  const int r = 3, P = 7, B = 2;
  const HostNetwork net = random_network(r, 12, 4, 0, 11);
  const std::vector<double> X = random_values(P * 3, -0.3, 0.3, 12);
  const std::vector<double> codes = random_values(B * r, -1, 1, 13);
  const std::vector<double> rates = random_values(B * r, -2, 2, 14);

  auto d = to_device<double, Mem>(net);
  Kokkos::View<double***, Kokkos::LayoutRight, Mem> g("g", B, P, 3), v("v", B, P, 3);
  Kokkos::View<double****, Kokkos::LayoutRight, Mem> F("F", B, P, 3, 3), J("J", B, P, 3, r);
  nn::evaluate_with_jacobians(ExecutionSpace(), d.mlp, nn::PointsView<double, Mem>(device_matrix<double, Mem>(X, P, 3)),
                              nn::CodesView<double, Mem>(device_matrix<double, Mem>(codes, B, r)),
                              nn::CodesView<double, Mem>(device_matrix<double, Mem>(rates, B, r)), g, F, J, v);
  auto gh = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), g);
  auto Fh = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), F);
  auto Jh = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), J);
  auto vh = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), v);

  // The position-only kernel does the same arithmetic in the same order.
  const std::vector<double> g0 = positions<ExecutionSpace>(net, X, codes);
  for (int b = 0; b < B; ++b)
    for (int p = 0; p < P; ++p)
      for (int k = 0; k < 3; ++k) EXPECT_NEAR(gh(b, p, k), g0[(b * P + p) * 3 + k], 4 * epsilon_of<double>());

  // Central differences: truncation h^2 |g'''| / 6 with |g'''| = O(1) for these weights, rounding eps |g| / h with
  // |g| < 1; h = 1e-5 balances them near 1e-10, and the factor 100 covers the O(1) constants.
  const double h = 1e-5;
  const double tol = 100 * (h * h + epsilon_of<double>() / h);
  // (g(X + h dX, codes + h dc) - g(X - h dX, codes - h dc)) / 2h against the kernel's derivative along (dX, dc)
  const auto expect_derivative = [&](const auto& kernel, const std::vector<double>& dX, const std::vector<double>& dc,
                                     double tolerance, const std::string& what) {
    std::vector<double> Xp = X, Xm = X, cp = codes, cm = codes;
    for (std::size_t i = 0; i < X.size(); ++i) {
      Xp[i] += h * dX[i];
      Xm[i] -= h * dX[i];
    }
    for (std::size_t i = 0; i < codes.size(); ++i) {
      cp[i] += h * dc[i];
      cm[i] -= h * dc[i];
    }
    const auto gp = positions<ExecutionSpace>(net, Xp, cp), gm = positions<ExecutionSpace>(net, Xm, cm);
    for (int b = 0; b < B; ++b)
      for (int p = 0; p < P; ++p)
        for (int k = 0; k < 3; ++k) {
          const std::size_t i = (b * P + p) * 3 + k;
          EXPECT_NEAR(kernel(b, p, k), (gp[i] - gm[i]) / (2 * h), tolerance) << what << " b=" << b << " p=" << p;
        }
  };
  const std::vector<double> no_dX(X.size(), 0.0), no_dc(codes.size(), 0.0);
  for (int dim = 0; dim < 3; ++dim) {
    std::vector<double> dX = no_dX;
    for (int p = 0; p < P; ++p) dX[p * 3 + dim] = 1;
    expect_derivative([&](int b, int p, int k) { return Fh(b, p, k, dim); }, dX, no_dc, tol, "dg/dX");
  }
  for (int q = 0; q < r; ++q) {
    std::vector<double> dc = no_dc;
    for (int b = 0; b < B; ++b) dc[b * r + q] = 1;
    expect_derivative([&](int b, int p, int k) { return Jh(b, p, k, q); }, no_dX, dc, tol, "dg/dxhat");
  }
  // The directional derivative along the rate: the rates are O(2), so the step along them is h.
  expect_derivative([&](int b, int p, int k) { return vh(b, p, k); }, no_dX, rates, 4 * tol, "velocity");
}

// A small auto-decoder problem: 4 snapshots of 6 points; a minibatch of 3 snapshots (one repeated through the rate
// stencil) with 4 samples each; random targets.
struct LossProblem {
  int r = 2, P = 6, S = 4, per_snapshot = 4;
  HostNetwork net;
  std::vector<double> X, x, F, v, CF;
  std::vector<int> point, snapshot{2, 0, 3}, rate_from{0, 0, 2, 2}, rate_to{1, 1, 3, 3};
  std::vector<double> rate_inv_dt{10, 10, 20, 20};
  nn::LossWeights<double> weights;

  LossProblem(double lambda_gradient, double lambda_velocity, double lambda_affine = 0) {
    net = random_network(r, 10, 4, S, 21);
    X = random_values(P * 3, -0.3, 0.3, 22);
    x = random_values(S * P * 3, -0.4, 0.4, 23);
    F = random_values(S * P * 9, 0.5, 1.5, 24);
    v = random_values(S * P * 3, -1, 1, 25);
    CF = random_values(S * P * 9, -2, 2, 27);
    std::mt19937_64 rng(26);
    for (std::size_t i = 0; i < snapshot.size() * per_snapshot; ++i) point.push_back(int(rng() % P));
    weights.lambda_gradient = lambda_gradient;
    weights.lambda_velocity = lambda_velocity;
    weights.position_scale = 0.1;
    weights.gradient_scale = 0.3;
    weights.lambda_affine = lambda_affine;
    weights.velocity_scale = 0.5;
    weights.affine_scale = 0.8;
  }
};

template <class ExecutionSpace, class T>
struct LossResult {
  double loss, affine_term;
  std::vector<double> grad;
};

// Loss (7) of the problem's minibatch with the given parameters, and its gradient when asked for. part: the batch
// snapshots (positions in problem.snapshot) one rank of a data-parallel run would hold, with only their targets on
// the device; its loss is its share of the whole minibatch's mean (empty: the whole minibatch).
template <class ExecutionSpace, class T>
LossResult<ExecutionSpace, T> evaluate_loss(const LossProblem& problem, const std::vector<double>& params,
                                            bool with_gradient, const std::vector<int>& part = {}) {
  using Mem = typename ExecutionSpace::memory_space;
  HostNetwork net = problem.net;
  net.params = params;
  auto d = to_device<T, Mem>(net);
  const auto channels = nn::Channels::make(problem.weights.lambda_gradient > 0, problem.weights.lambda_velocity > 0,
                                           problem.weights.lambda_affine > 0);

  auto ints = [](const std::vector<int>& values) {
    Kokkos::View<int*, Mem> view("ints", values.size());
    auto host = Kokkos::create_mirror_view(view);
    for (std::size_t i = 0; i < values.size(); ++i) host(i) = values[i];
    Kokkos::deep_copy(view, host);
    return view;
  };
  auto cube = [](const std::vector<double>& values, int n0, int n1, int n2) {
    Kokkos::View<T***, Kokkos::LayoutRight, Mem> view("cube", n0, n1, n2);
    auto host = Kokkos::create_mirror_view(view);
    for (std::size_t i = 0; i < values.size(); ++i) host.data()[i] = T(values[i]);
    Kokkos::deep_copy(view, host);
    return view;
  };
  nn::BatchSamples<T, Mem> batch;
  batch.samples_per_snapshot = problem.per_snapshot;
  batch.X = device_matrix<T, Mem>(problem.X, problem.P, 3);
  if (part.empty()) {
    batch.point = ints(problem.point);
    batch.snapshot = ints(problem.snapshot);
    batch.row = batch.snapshot;
    batch.x = cube(problem.x, problem.S, problem.P, 3);
    batch.F = cube(problem.F, problem.S, problem.P, 9);
    batch.v = cube(problem.v, problem.S, problem.P, 3);
    batch.CF = cube(problem.CF, problem.S, problem.P, 9);
  } else {
    std::vector<int> snapshots, rows, points;
    std::vector<double> x, F, v, CF;
    const std::size_t P = std::size_t(problem.P), per = std::size_t(problem.per_snapshot);
    for (const int position : part) {
      const std::size_t s = std::size_t(problem.snapshot[std::size_t(position)]);
      rows.push_back(int(snapshots.size()));
      snapshots.push_back(int(s));
      points.insert(points.end(), problem.point.begin() + long(position * per),
                    problem.point.begin() + long((position + 1) * per));
      x.insert(x.end(), problem.x.begin() + long(s * P * 3), problem.x.begin() + long((s + 1) * P * 3));
      F.insert(F.end(), problem.F.begin() + long(s * P * 9), problem.F.begin() + long((s + 1) * P * 9));
      v.insert(v.end(), problem.v.begin() + long(s * P * 3), problem.v.begin() + long((s + 1) * P * 3));
      CF.insert(CF.end(), problem.CF.begin() + long(s * P * 9), problem.CF.begin() + long((s + 1) * P * 9));
    }
    batch.point = ints(points);
    batch.snapshot = ints(snapshots);
    batch.row = ints(rows);
    batch.x = cube(x, int(rows.size()), problem.P, 3);
    batch.F = cube(F, int(rows.size()), problem.P, 9);
    batch.v = cube(v, int(rows.size()), problem.P, 3);
    batch.CF = cube(CF, int(rows.size()), problem.P, 9);
    batch.total_samples = long(problem.point.size());
  }

  nn::CodeTable<T, Mem> table;
  table.code_offset = net.layout.num_params;
  table.latent_dim = problem.r;
  table.rate_from = ints(problem.rate_from);
  table.rate_to = ints(problem.rate_to);
  Kokkos::View<T*, Mem> inv_dt("inv_dt", problem.S);
  auto inv_dt_host = Kokkos::create_mirror_view(inv_dt);
  for (int s = 0; s < problem.S; ++s) inv_dt_host(s) = T(problem.rate_inv_dt[s]);
  Kokkos::deep_copy(inv_dt, inv_dt_host);
  table.rate_inv_dt = inv_dt;

  nn::LossWeights<T> weights;
  weights.lambda_gradient = T(problem.weights.lambda_gradient);
  weights.lambda_velocity = T(problem.weights.lambda_velocity);
  weights.position_scale = T(problem.weights.position_scale);
  weights.gradient_scale = T(problem.weights.gradient_scale);
  weights.velocity_scale = T(problem.weights.velocity_scale);
  weights.lambda_affine = T(problem.weights.lambda_affine);
  weights.affine_scale = T(problem.weights.affine_scale);

  const int batch_snapshots = int(batch.snapshot.extent(0));
  nn::TrainingBuffers<T, Mem> buffers(ExecutionSpace(), net.layout, channels, batch_snapshots * problem.per_snapshot,
                                      batch_snapshots);
  Kokkos::View<T*, Mem> grad("grad", with_gradient ? params.size() : 0);
  const auto terms = nn::minibatch_loss(ExecutionSpace(), d.mlp, table, channels, weights, batch, buffers, grad);
  LossResult<ExecutionSpace, T> result;
  result.loss = double(terms.position) + problem.weights.lambda_gradient * double(terms.gradient) +
                problem.weights.lambda_velocity * double(terms.velocity) +
                problem.weights.lambda_affine * double(terms.affine);
  result.affine_term = double(terms.affine);
  auto grad_host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), grad);
  result.grad.assign(grad_host.data(), grad_host.data() + grad_host.size());
  return result;
}

template <class ExecutionSpace>
void check_loss_gradient_against_finite_differences(double lambda_gradient, double lambda_velocity,
                                                    double lambda_affine = 0) {
  const LossProblem problem(lambda_gradient, lambda_velocity, lambda_affine);
  const auto exact = evaluate_loss<ExecutionSpace, double>(problem, problem.net.params, true);
  ASSERT_EQ(exact.grad.size(), problem.net.params.size());
  // Central differences in double: rounding of the loss is eps |loss| / h, truncation h^2 |loss'''| / 6 with
  // |loss'''| = O(10) for these weights and scales; h = 1e-6 keeps both below 1e-9 |loss|.
  const double h = 1e-6;
  const double tol = 100 * (h * h * 10 + epsilon_of<double>() * exact.loss / h);
  int checked_codes = 0;
  for (std::size_t i = 0; i < problem.net.params.size(); ++i) {
    std::vector<double> plus = problem.net.params, minus = problem.net.params;
    plus[i] += h;
    minus[i] -= h;
    const double fd = (evaluate_loss<ExecutionSpace, double>(problem, plus, false).loss -
                       evaluate_loss<ExecutionSpace, double>(problem, minus, false).loss) /
                      (2 * h);
    EXPECT_NEAR(exact.grad[i], fd, tol) << "parameter " << i
                                        << (int(i) >= problem.net.layout.num_params ? " (code)" : "");
    if (int(i) >= problem.net.layout.num_params && exact.grad[i] != 0) ++checked_codes;
  }
  // Codes 0, 2, 3 are in the batch and codes 1 and 3 enter through the rates: with a velocity term every code has a
  // gradient, without one code 1 has none.
  EXPECT_EQ(checked_codes, problem.r * (lambda_velocity > 0 || lambda_affine > 0 ? 4 : 3));
}

template <class ExecutionSpace>
void check_float_matches_double(double lambda_affine = 0) {
  const LossProblem problem(1.0, 1.0, lambda_affine);
  const auto d = evaluate_loss<ExecutionSpace, double>(problem, problem.net.params, true);
  const auto f = evaluate_loss<ExecutionSpace, float>(problem, problem.net.params, true);
  double largest = 0;
  for (double g : d.grad) largest = std::max(largest, std::abs(g));
  // float rounding (6e-8) amplified by sums of O(100) terms through 4 layers stays below 1e-5 relative; 1e-4 is
  // the bound.
  EXPECT_NEAR(f.loss, d.loss, 1e-4 * d.loss);
  for (std::size_t i = 0; i < d.grad.size(); ++i) EXPECT_NEAR(f.grad[i], d.grad[i], 1e-4 * largest) << i;
}

template <class ExecutionSpace>
void check_gradient_is_deterministic() {
  const LossProblem problem(1.0, 1.0);
  const auto a = evaluate_loss<ExecutionSpace, double>(problem, problem.net.params, true);
  const auto b = evaluate_loss<ExecutionSpace, double>(problem, problem.net.params, true);
  EXPECT_EQ(a.loss, b.loss);
  EXPECT_EQ(a.grad, b.grad);
}

// The team evaluation of the kinematics (one point per team thread, its lanes sharing the network) against the
// one-thread one, for networks whose widths fill the lanes unevenly, with the weights staged in scratch or read from
// memory, threads without a point and threads not asking for dg/dxhat in a team that does; and its primal channel
// alone (position_only: g and dg/dxhat, what the reduced model's samples and grid-strain nodes need).
template <class ExecutionSpace>
struct TeamKinematicsRun {
  using MemorySpace = typename ExecutionSpace::memory_space;
  using member_type = typename Kokkos::TeamPolicy<ExecutionSpace>::member_type;
  static constexpr int outputs = 24;  // g, F, v, Fdot

  nn::TeamMlp<double, MemorySpace> net;
  Kokkos::View<const double**, Kokkos::LayoutRight, MemorySpace> X, xhat, xhatdot;  // per item
  Kokkos::View<double**, Kokkos::LayoutRight, MemorySpace> kinematics, jacobian;    // per item
  int threads, per_thread;
  bool stage, position_only;

  // Items asking for dg/dxhat: the even ones.
  KOKKOS_INLINE_FUNCTION static bool wants_jacobian(long e) { return e % 2 == 0; }

  KOKKOS_INLINE_FUNCTION void operator()(const member_type& member) const {
    const long items = long(X.extent(0));
    const long first = long(member.league_rank()) * threads, e = first + member.team_rank();
    const bool active = e < items;
    bool any_jacobian = false;
    for (long f = first; f < first + threads && f < items; ++f) any_jacobian = any_jacobian || wants_jacobian(f);
    const int shared = stage ? net.arranged.size : 0;
    double* base = static_cast<double*>(
        member.team_scratch(0).get_shmem_aligned(std::size_t(shared + threads * per_thread) * sizeof(double), 64));
    const double* weights = net.values.data();
    if (stage) {
      const auto values = net.values;
      Kokkos::parallel_for(Kokkos::TeamVectorRange(member, shared), [&](const int i) { base[i] = values(i); });
      member.team_barrier();
      weights = base;
    }
    double* own = base + shared + member.team_rank() * per_thread;
    auto& kin = *reinterpret_cast<nn::PointKinematics<double>*>(own + per_thread - outputs);
    const long i = active ? e : 0;
    const double Xi[3] = {X(i, 0), X(i, 1), X(i, 2)};
    double* J = active && wants_jacobian(e) ? &jacobian(i, 0) : nullptr;
    if (position_only)
      nn::TeamMlpKinematics<1>(member, net, weights, own, active, Xi, &xhat(i, 0), &xhatdot(i, 0), any_jacobian, kin,
                               J);
    else
      nn::TeamMlpKinematics(member, net, weights, own, active, Xi, &xhat(i, 0), &xhatdot(i, 0), any_jacobian, kin, J);
    member.team_barrier();
    Kokkos::parallel_for(Kokkos::ThreadVectorRange(member, active ? outputs : 0),
                         [&](const int c) { kinematics(i, c) = reinterpret_cast<const double*>(&kin)[c]; });
  }
};

template <class ExecutionSpace>
void check_team_kinematics_match_serial() {
  using MemorySpace = typename ExecutionSpace::memory_space;
  using Run = TeamKinematicsRun<ExecutionSpace>;
  const bool host = Kokkos::SpaceAccessibility<Kokkos::HostSpace, MemorySpace>::accessible;
  struct Shape {
    int latent, width, depth;
  };
  for (const Shape shape : {Shape{5, 16, 5}, Shape{3, 20, 3}, Shape{7, 48, 4}, Shape{2, 5, 2}}) {
    const HostNetwork host_net = random_network(shape.latent, shape.width, shape.depth, 0, 11);
    const nn::MlpLayout& layout = host_net.layout;
    const int r = layout.latent_dim, items = 11;
    std::mt19937_64 rng(5);
    std::uniform_real_distribution<double> uniform(-1, 1);
    std::vector<double> X(3 * items), xhat(r * items), xhatdot(r * items);
    for (double& v : X) v = 0.3 * uniform(rng);
    for (double& v : xhat) v = uniform(rng);
    for (double& v : xhatdot) v = uniform(rng);
    Kokkos::View<double*, Kokkos::HostSpace> host_params("params", host_net.params.size());
    for (std::size_t i = 0; i < host_net.params.size(); ++i) host_params(i) = host_net.params[i];
    nn::Mlp<double, Kokkos::HostSpace> serial{layout, host_net.standardization, host_params};

    nn::TeamMlp<double, MemorySpace> net;
    net.layout = layout;
    net.arranged = nn::TeamMlpLayout::make(layout);
    net.standardization = host_net.standardization;
    const std::vector<double> arranged = nn::arrange_for_teams<double>(layout, net.arranged, host_net.params);
    Kokkos::View<double*, MemorySpace> values("values", arranged.size());
    Kokkos::deep_copy(values, Kokkos::View<const double*, Kokkos::HostSpace>(arranged.data(), arranged.size()));
    net.values = values;
    const auto matrix = [](const std::vector<double>& values, int columns) {
      Kokkos::View<double**, Kokkos::LayoutRight, MemorySpace> view("m", values.size() / columns, columns);
      auto mirror = Kokkos::create_mirror_view(view);
      for (std::size_t i = 0; i < values.size(); ++i) mirror.data()[i] = values[i];
      Kokkos::deep_copy(view, mirror);
      return view;
    };
    const int lanes_max = host ? 1 : 32;
    for (int lanes = 1; lanes <= lanes_max; lanes *= 2) {
      for (const auto& [stage, position_only] :
           std::initializer_list<std::pair<bool, bool>>{{false, false}, {true, false}, {false, true}}) {
        const int threads = host ? 1 : 3;
        if (stage && net.arranged.size * sizeof(double) > 32 * 1024)
          continue;  // as the ROM: weights in scratch if small
        Run run{net,
                matrix(X, 3),
                matrix(xhat, r),
                matrix(xhatdot, r),
                Kokkos::View<double**, Kokkos::LayoutRight, MemorySpace>("kinematics", items, Run::outputs),
                Kokkos::View<double**, Kokkos::LayoutRight, MemorySpace>("jacobian", items, 3 * r),
                threads,
                (net.thread_scratch_values() + Run::outputs + 7) / 8 * 8,
                stage,
                position_only};
        const std::size_t bytes = std::size_t((stage ? net.arranged.size : 0) + threads * run.per_thread) * 8 + 64;
        Kokkos::parallel_for(Kokkos::TeamPolicy<ExecutionSpace>((items + threads - 1) / threads, threads, lanes)
                                 .set_scratch_size(0, Kokkos::PerTeam(bytes)),
                             run);
        const auto kinematics = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), run.kinematics);
        const auto jacobian = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), run.jacobian);
        for (int e = 0; e < items; ++e) {
          nn::PointKinematics<double> expected;
          std::vector<double> J(3 * r);
          nn::SerialMlpKinematics<64>(serial, &X[3 * e], &xhat[r * e], &xhatdot[r * e], expected, J.data());
          // The same sums in the same order; only contraction into fused multiply-adds may differ: a few eps of the
          // summed magnitudes (inputs and weights of order one, activations of order ten at most).
          const double tolerance = 1e-12;
          const double* want = reinterpret_cast<const double*>(&expected);
          for (int c = 0; c < (position_only ? 3 : Run::outputs); ++c)
            EXPECT_NEAR(kinematics(e, c), want[c], tolerance)
                << "width " << shape.width << " lanes " << lanes << " stage " << stage << " position only "
                << position_only << " item " << e << " value " << c;
          if (!Run::wants_jacobian(e)) continue;
          for (int q = 0; q < 3 * r; ++q)
            EXPECT_NEAR(jacobian(e, q), J[q], tolerance)
                << "width " << shape.width << " lanes " << lanes << " stage " << stage << " position only "
                << position_only << " item " << e << " entry " << q;
        }
      }
    }
  }
}

// The training's mixed channels are the kinematics' Fdot: with C F targets set to SerialMlpKinematics' Fdot at each
// sample's code and stencil rate, the affine term vanishes to rounding (against O(1) for the random targets).
template <class ExecutionSpace>
void check_affine_term_is_the_kinematics_fdot() {
  LossProblem problem(0, 0, 1.0);
  const auto host = to_device<double, Kokkos::HostSpace>(problem.net);
  const int r = problem.r, num_weights = problem.net.layout.num_params;
  const auto code = [&](int s, int q) { return problem.net.params[std::size_t(num_weights + s * r + q)]; };
  for (std::size_t position = 0; position < problem.snapshot.size(); ++position) {
    const int s = problem.snapshot[position];
    std::vector<double> xhat(r), xhatdot(r);
    for (int q = 0; q < r; ++q) {
      xhat[q] = code(s, q);
      xhatdot[q] = (code(problem.rate_to[s], q) - code(problem.rate_from[s], q)) * problem.rate_inv_dt[s];
    }
    for (std::size_t k = 0; k < std::size_t(problem.per_snapshot); ++k) {
      const int p = problem.point[position * problem.per_snapshot + k];
      nn::PointKinematics<double> kin;
      nn::SerialMlpKinematics<64>(host.mlp, &problem.X[3 * p], xhat.data(), xhatdot.data(), kin,
                                  static_cast<double*>(nullptr));
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) problem.CF[std::size_t((s * problem.P + p) * 9 + 3 * i + j)] = kin.Fdot[i][j];
    }
  }
  const double random_term =
      evaluate_loss<ExecutionSpace, double>(LossProblem(0, 0, 1.0), problem.net.params, false).affine_term;
  const double term = evaluate_loss<ExecutionSpace, double>(problem, problem.net.params, false).affine_term;
  ASSERT_GT(random_term, 0.1);
  // The same products summed in another order: residuals of a few eps of Fdot's O(10) magnitude, squared.
  EXPECT_LT(term, 1e-24);
}

template <class ExecutionSpace>
class Mlp : public ::testing::Test {};
// Data-parallel training: the minibatch split between two ranks (batch snapshot 0 on one, 1 and 2 on the other,
// each with only its snapshots' targets) gives losses and gradients that sum to the whole minibatch's.
template <class ExecutionSpace>
void check_split_minibatch_sums_to_whole() {
  const LossProblem problem(0.7, 0.4);
  const auto whole = evaluate_loss<ExecutionSpace, double>(problem, problem.net.params, true);
  const auto first = evaluate_loss<ExecutionSpace, double>(problem, problem.net.params, true, {0});
  const auto second = evaluate_loss<ExecutionSpace, double>(problem, problem.net.params, true, {1, 2});
  // The same 12 samples' terms summed in another order: a few eps of the summed magnitudes, which cancellation
  // between samples can make up to ~100 times the result; 1e-12 relative is above both.
  EXPECT_NEAR(first.loss + second.loss, whole.loss, 1e-12 * whole.loss);
  double largest = 0;
  for (const double g : whole.grad) largest = std::max(largest, std::abs(g));
  ASSERT_GT(largest, 0);
  for (std::size_t i = 0; i < whole.grad.size(); ++i)
    EXPECT_NEAR(first.grad[i] + second.grad[i], whole.grad[i], 1e-12 * largest) << "parameter " << i;
}

// The CPU's block kernels (mlp_block.hpp) against the one-point kernels, lane by lane, on the poke model's shape (5
// layers of 48, r = 5), the kinematics' second-order channels included: 13 points at 13 codes, so that the second block
// repeats its last point in 3 lanes. The two run the same sums in the same order and differ only where the compiler
// fuses a multiply-add (one rounding of a term instead of two, at most eps |w h|): with |w| ~ 1.5 / sqrt(48) and O(1)
// activations, a layer's 48 terms carry at most 48 eps of error and 5 layers, each of gain below 2, at most 5 x 48 x
// 2^5 eps, about 8000 eps, on outputs of order one (the standardisation scales them down further).
TEST(MlpBlock, BlockKernelsMatchOnePointKernels) {
  const int r = 5, P = 13;
  const HostNetwork net = random_network(r, 48, 5, 0, 21);
  const auto d = to_device<double, Kokkos::HostSpace>(net);
  const std::vector<double> X = random_values(P * 3, -0.3, 0.3, 22), codes = random_values(P * r, -1, 1, 23);
  const double tol = 8000 * epsilon_of<double>();
  constexpr int Lanes = nn::host_block_lanes;
  for (int first = 0; first < P; first += Lanes) {
    nn::PointBlock<Lanes, double> points;
    for (int lane = 0; lane < Lanes; ++lane) {
      const int p = std::min(first + lane, P - 1);
      for (int k = 0; k < 3; ++k) points.X[lane][k] = X[3 * p + k];
      points.xhat[lane] = &codes[std::size_t(r * p)];
    }
    double g[Lanes][3], g_only[Lanes][3], F[Lanes][3][3], J[Lanes][3 * 5], Jk[Lanes][3 * 5];
    double *Jp[Lanes], *Jkp[Lanes];
    const double* rates[Lanes];
    for (int lane = 0; lane < Lanes; ++lane) {
      Jp[lane] = J[lane];
      Jkp[lane] = lane % 3 == 0 ? Jk[lane] : nullptr;  // the kinematics' dg/dxhat for some lanes only
      rates[lane] = &codes[std::size_t(r * ((lane + 5) % P))];
    }
    nn::BlockMlpForwardJacobian<Lanes, 64>(d.mlp, points, g, F, Jp);
    nn::BlockMlpForward<Lanes, 64>(d.mlp, points, g_only);
    nn::PointKinematics<double> kin[Lanes];
    nn::BlockMlpKinematics<Lanes, 64>(d.mlp, points, rates, kin, Jkp);
    for (int lane = 0; lane < Lanes; ++lane) {
      double g1[3], F1[3][3], J1[3 * 5];
      nn::SerialMlpForwardJacobian<64>(d.mlp, points.X[lane], points.xhat[lane], g1, F1, J1);
      double g2[3];
      nn::SerialMlpForward<64>(d.mlp, points.X[lane], points.xhat[lane], g2);
      nn::PointKinematics<double> kin1;
      double Jk1[3 * 5];
      nn::SerialMlpKinematics<64>(d.mlp, points.X[lane], points.xhat[lane], rates[lane], kin1, Jk1);
      for (int k = 0; k < 3; ++k) {
        EXPECT_NEAR(g[lane][k], g1[k], tol) << "block " << first << " lane " << lane;
        EXPECT_NEAR(g_only[lane][k], g2[k], tol) << "block " << first << " lane " << lane;
        EXPECT_NEAR(kin[lane].g[k], kin1.g[k], tol) << "block " << first << " lane " << lane;
        EXPECT_NEAR(kin[lane].v[k], kin1.v[k], tol * std::max(1.0, std::fabs(kin1.v[k])));
        for (int j = 0; j < 3; ++j) {
          EXPECT_NEAR(F[lane][k][j], F1[k][j], tol * std::max(1.0, std::fabs(F1[k][j])));
          EXPECT_NEAR(kin[lane].F[k][j], kin1.F[k][j], tol * std::max(1.0, std::fabs(kin1.F[k][j])));
          EXPECT_NEAR(kin[lane].Fdot[k][j], kin1.Fdot[k][j], tol * std::max(1.0, std::fabs(kin1.Fdot[k][j])));
        }
        for (int q = 0; q < r; ++q) {
          EXPECT_NEAR(J[lane][k * r + q], J1[k * r + q], tol);
          if (Jkp[lane] != nullptr) EXPECT_NEAR(Jk[lane][k * r + q], Jk1[k * r + q], tol);
        }
      }
    }
  }
}

TYPED_TEST_SUITE(Mlp, EnabledBackends, BackendName);

TYPED_TEST(Mlp, JacobiansMatchFiniteDifferences) { check_jacobians_against_finite_differences<TypeParam>(); }
TYPED_TEST(Mlp, PositionLossGradientMatchesFiniteDifferences) {
  check_loss_gradient_against_finite_differences<TypeParam>(0, 0);
}
TYPED_TEST(Mlp, VelocityLossGradientMatchesFiniteDifferences) {
  check_loss_gradient_against_finite_differences<TypeParam>(0, 0.7);
}
TYPED_TEST(Mlp, FullLossGradientMatchesFiniteDifferences) {
  check_loss_gradient_against_finite_differences<TypeParam>(2.0, 0.7);
}
TYPED_TEST(Mlp, AffineLossGradientMatchesFiniteDifferences) {
  check_loss_gradient_against_finite_differences<TypeParam>(0, 0, 1.3);
  check_loss_gradient_against_finite_differences<TypeParam>(2.0, 0.7, 1.3);
}
TYPED_TEST(Mlp, AffineTermIsTheKinematicsFdot) { check_affine_term_is_the_kinematics_fdot<TypeParam>(); }
TYPED_TEST(Mlp, AffineTermsFloatMatchesDouble) { check_float_matches_double<TypeParam>(1.3); }
TYPED_TEST(Mlp, FloatKernelsMatchDouble) { check_float_matches_double<TypeParam>(); }
TYPED_TEST(Mlp, GradientIsBitwiseReproducible) { check_gradient_is_deterministic<TypeParam>(); }
TYPED_TEST(Mlp, SplitMinibatchSumsToTheWhole) { check_split_minibatch_sums_to_whole<TypeParam>(); }
TYPED_TEST(Mlp, TeamKinematicsMatchSerial) { check_team_kinematics_match_serial<TypeParam>(); }

}  // namespace
