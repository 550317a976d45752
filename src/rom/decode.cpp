// The trained network evaluated for the reduced model: positions at the training codes, Jacobians, decoded fields.
#include <Kokkos_Core.hpp>

#include <algorithm>
#include <vector>

#include "manifold/device_data.hpp"
#include "manifold/nn/mlp_batch.hpp"
#include "mpmrom/rom.hpp"
#include "rom/detail/decoder.hpp"

namespace mpmrom {
namespace {

using ExecutionSpace = Kokkos::DefaultExecutionSpace;
using MemorySpace = ExecutionSpace::memory_space;
using Vector = impl::DeviceVector;
using Matrix = impl::DeviceMatrix;
using Cube = impl::DeviceCube;
using Quad = impl::DeviceQuad;
using impl::download;
using impl::upload;
using Codes = nn::CodesView<real_t, MemorySpace>;

struct NetworkFields {
  Cube x, v;  // (codes, n, 3)
  Quad F, J;  // (codes, n, 3, 3), (codes, n, 3, r)
};

// The network at points X (n, 3) for each of codes (count, r): positions, deformation gradients, dg/dxhat and, given
// rates (count, r; nullptr: none), velocities.
NetworkFields evaluate_network(const Model& model, const std::vector<double>& X, const std::vector<double>& codes,
                               const std::vector<double>* rates) {
  const int r = model.latent_dim;
  const std::size_t n = X.size() / 3, count = codes.size() / std::size_t(r);
  const Vector params = upload<Vector>("mpmrom::rom::params", model.weights, model.layout().num_params);
  NetworkFields out{Cube("mpmrom::rom::decode_x", count, n, 3),
                    rates == nullptr ? Cube() : Cube("mpmrom::rom::decode_v", count, n, 3),
                    Quad("mpmrom::rom::decode_F", count, n, 3, 3), Quad("mpmrom::rom::decode_J", count, n, 3, r)};
  nn::evaluate_with_jacobians(ExecutionSpace(), impl::device_mlp(model, params),
                              nn::PointsView<real_t, MemorySpace>(upload<Matrix>("X", X, n, 3)),
                              Codes(upload<Matrix>("codes", codes, count, r)),
                              rates == nullptr ? Codes() : Codes(upload<Matrix>("rates", *rates, count, r)), out.x,
                              out.F, out.J, out.v);
  return out;
}

}  // namespace

std::vector<double> impl::training_positions(const Model& model, const std::vector<int>& chosen) {
  const nn::MlpLayout layout = model.layout();
  const Vector params = upload<Vector>("mpmrom::rom::params", model.weights, layout.num_params);
  const auto mlp = impl::device_mlp(model, params);
  const std::size_t P = model.num_points(), C = chosen.empty() ? model.num_codes() : chosen.size();
  const std::size_t r = std::size_t(model.latent_dim);
  std::vector<double> values = model.codes;
  if (!chosen.empty()) {
    values.resize(C * r);
    for (std::size_t c = 0; c < C; ++c) std::copy_n(&model.codes.at(std::size_t(chosen[c]) * r), r, &values[c * r]);
  }
  const Matrix X = upload<Matrix>("mpmrom::rom::X", model.X, P, 3);
  const Matrix codes = upload<Matrix>("mpmrom::rom::codes", values, C, model.latent_dim);
  Cube g("mpmrom::rom::training_positions", C, P, 3);
  nn::evaluate(ExecutionSpace(), mlp, nn::PointsView<real_t, MemorySpace>(X), Codes(codes), g);
  return download(g);
}

std::vector<double> impl::decoder_jacobians(const Model& model, const std::vector<double>& X,
                                            const std::vector<double>& codes) {
  return download(evaluate_network(model, X, codes, nullptr).J);
}

DecodedFields impl::decode_in_passes(const Model& model, const std::vector<double>& X, const std::vector<double>& codes,
                                     const std::vector<double>& rates, std::size_t values_per_pass) {
  const std::size_t r = std::size_t(model.latent_dim), n = X.size() / 3, count = codes.size() / r;
  const std::size_t per_pass = std::max<std::size_t>(1, values_per_pass / std::max<std::size_t>(1, n * 3 * r));
  const auto append = [](std::vector<double>& to, const std::vector<double>& from) {
    to.insert(to.end(), from.begin(), from.end());
  };
  DecodedFields out;
  for (std::size_t first = 0; first < count; first += per_pass) {
    const auto from = std::ptrdiff_t(first * r), to = std::ptrdiff_t(std::min(count, first + per_pass) * r);
    const std::vector<double> some_rates(rates.begin() + from, rates.begin() + to);
    const NetworkFields fields =
        evaluate_network(model, X, std::vector<double>(codes.begin() + from, codes.begin() + to), &some_rates);
    append(out.x, download(fields.x));
    append(out.v, download(fields.v));
    append(out.F, download(fields.F));
  }
  return out;
}

DecodedFields decode(const Model& model, const std::vector<double>& X, const std::vector<double>& codes,
                     const std::vector<double>& rates) {
  // A few codes a pass: the network's pass holds dg/dxhat (3 r values a point) beside the fields, which for all 36
  // frames of a 10^6-point rollout at r = 16 took more than 24 GB; 2^26 values of it are 512 MiB in double.
  return impl::decode_in_passes(model, X, codes, rates, std::size_t(1) << 26);
}

}  // namespace mpmrom
