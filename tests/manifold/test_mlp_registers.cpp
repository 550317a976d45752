// The narrow network's one-thread evaluation with its activations in registers (src/manifold/nn/mlp_registers.hpp)
// against the one-thread evaluation it replaces for g and dg/dxhat (SerialMlpForwardJacobian), on every backend, for
// networks that fill the padded width unevenly, at the widest latent dimension it takes and at the most layers.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "backends.hpp"
#include "random_network.hpp"
#include "manifold/nn/mlp.hpp"
#include "manifold/nn/mlp_registers.hpp"

namespace {

using namespace mpmrom;
using mpmrom::test::BackendName;
using mpmrom::test::EnabledBackends;
using mpmrom::test::HostNetwork;

struct Shape {
  int latent, width, depth;
};

template <class T, class MemorySpace>
struct Evaluate {
  nn::RegisterMlp<T, MemorySpace> net;
  Kokkos::View<const T**, Kokkos::LayoutRight, MemorySpace> X, xhat;  // per item
  Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace> g, jacobian;    // per item

  KOKKOS_INLINE_FUNCTION void operator()(const int e) const {
    const T Xe[3] = {X(e, 0), X(e, 1), X(e, 2)};
    T ge[3];
    nn::RegisterMlpPositionAndTangent(net, Xe, &xhat(e, 0), ge, &jacobian(e, 0));
    for (int d = 0; d < 3; ++d) g(e, d) = ge[d];
  }
};

template <class T, class MemorySpace>
Kokkos::View<const T**, Kokkos::LayoutRight, MemorySpace> device_matrix(const std::vector<double>& values,
                                                                        int columns) {
  Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace> view("matrix", values.size() / columns, columns);
  const auto host = Kokkos::create_mirror_view(view);
  for (std::size_t i = 0; i < values.size(); ++i) host.data()[i] = T(values[i]);
  Kokkos::deep_copy(view, host);
  return view;
}

// g and dg/dxhat of `items` random points and codes by the register kernel in precision T: (items x 3, items x 3r).
template <class ExecutionSpace, class T>
void evaluate_registers(const HostNetwork& host_net, const std::vector<double>& X, const std::vector<double>& xhat,
                        std::vector<double>& g, std::vector<double>& jacobian) {
  using MemorySpace = typename ExecutionSpace::memory_space;
  const nn::MlpLayout& layout = host_net.layout;
  const int r = layout.latent_dim, items = int(X.size() / 3);
  nn::RegisterMlp<T, MemorySpace> net{layout.num_layers, r, {}, {}};
  for (int d = 0; d < 3; ++d) {
    net.standardization.input_mean[d] = T(host_net.standardization.input_mean[d]);
    net.standardization.input_scale[d] = T(host_net.standardization.input_scale[d]);
    net.standardization.output_mean[d] = T(host_net.standardization.output_mean[d]);
    net.standardization.output_scale[d] = T(host_net.standardization.output_scale[d]);
  }
  const std::vector<T> padded = nn::arrange_for_registers<T>(layout, host_net.params);
  Kokkos::View<nn::WeightQuad<T>*, MemorySpace> quads("quads", padded.size() / 4);
  const auto host_quads = Kokkos::create_mirror_view(quads);
  for (std::size_t i = 0; i < padded.size(); ++i) host_quads(i / 4).v[i % 4] = padded[i];
  Kokkos::deep_copy(quads, host_quads);
  net.quads = quads;
  const Evaluate<T, MemorySpace> run{net, device_matrix<T, MemorySpace>(X, 3), device_matrix<T, MemorySpace>(xhat, r),
                                     Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>("g", items, 3),
                                     Kokkos::View<T**, Kokkos::LayoutRight, MemorySpace>("J", items, 3 * r)};
  Kokkos::parallel_for(Kokkos::RangePolicy<ExecutionSpace>(0, items), run);
  const auto g_host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), run.g);
  const auto J_host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), run.jacobian);
  g.assign(g_host.data(), g_host.data() + g_host.size());
  jacobian.assign(J_host.data(), J_host.data() + J_host.size());
}

template <class ExecutionSpace>
class MlpRegisters : public ::testing::Test {};
TYPED_TEST_SUITE(MlpRegisters, EnabledBackends, BackendName);

TYPED_TEST(MlpRegisters, MatchTheSerialForwardJacobian) {
  // 16 wide with 5 layers (the batch benchmarks' network), uneven widths, r = 13 (3 + r fills the width), the most
  // layers, and one layer of two
  for (const Shape shape :
       {Shape{5, 16, 5}, Shape{3, 10, 3}, Shape{13, 16, 4}, Shape{2, 7, nn::max_layers}, Shape{1, 3, 2}}) {
    const HostNetwork host_net = test::random_network(shape.latent, shape.width, shape.depth, 0, 7);
    ASSERT_TRUE((nn::RegisterMlp<double, Kokkos::HostSpace>::fits(host_net.layout)));
    const int r = shape.latent, items = 37;
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> uniform(-1, 1);
    std::vector<double> X(3 * items), xhat(r * items);
    for (double& v : X) v = 0.3 * uniform(rng);
    for (double& v : xhat) v = 2 * uniform(rng);  // codes beyond the unit box: ELUs on both sides of zero
    std::vector<double> g, J, g_float, J_float;
    evaluate_registers<TypeParam, double>(host_net, X, xhat, g, J);
    evaluate_registers<TypeParam, float>(host_net, X, xhat, g_float, J_float);

    Kokkos::View<double*, Kokkos::HostSpace> params("params", host_net.params.size());
    for (std::size_t i = 0; i < host_net.params.size(); ++i) params(i) = host_net.params[i];
    const nn::Mlp<double, Kokkos::HostSpace> serial{host_net.layout, host_net.standardization, params};
    for (int e = 0; e < items; ++e) {
      double want_g[3], unused[3][3];
      std::vector<double> want_J(3 * r);
      nn::SerialMlpForwardJacobian<nn::max_width>(serial, &X[3 * e], &xhat[r * e], want_g, unused, want_J.data());
      // The same sums in the same order plus exact zeros: only contraction into fused multiply-adds may differ, a few
      // eps of the summed magnitudes (inputs and weights of order one, activations of order ten at most). Float:
      // its eps (6e-8) times the same magnitudes, through up to 8 layers.
      for (int d = 0; d < 3; ++d) {
        EXPECT_NEAR(g[3 * e + d], want_g[d], 1e-12) << "r " << r << " width " << shape.width << " item " << e;
        EXPECT_NEAR(g_float[3 * e + d], want_g[d], 2e-5) << "r " << r << " width " << shape.width << " item " << e;
      }
      for (int q = 0; q < 3 * r; ++q) {
        EXPECT_NEAR(J[3 * r * e + q], want_J[q], 1e-12) << "r " << r << " width " << shape.width << " entry " << q;
        EXPECT_NEAR(J_float[3 * r * e + q], want_J[q], 2e-5) << "r " << r << " width " << shape.width << " entry " << q;
      }
    }
  }
}

TEST(MlpRegistersLayout, TakesNetworksUpToTheRegisterWidth) {
  EXPECT_TRUE((nn::RegisterMlp<double, Kokkos::HostSpace>::fits(nn::MlpLayout::make(13, 16, 5))));
  EXPECT_FALSE((nn::RegisterMlp<double, Kokkos::HostSpace>::fits(nn::MlpLayout::make(14, 16, 5))));  // 3 + r = 17
  EXPECT_FALSE((nn::RegisterMlp<double, Kokkos::HostSpace>::fits(nn::MlpLayout::make(5, 17, 5))));
}

}  // namespace
