// Moving host vectors to and from device Views, and a model's network as a device Mlp: shared by the trainer and
// the reduced model.
#pragma once

#include <Kokkos_Core.hpp>

#include <string>
#include <vector>

#include "manifold/nn/mlp.hpp"
#include "mpmrom/model.hpp"
#include "mpmrom/mpmrom_config.hpp"

namespace mpmrom::impl {

using DeviceMemory = Kokkos::DefaultExecutionSpace::memory_space;
// Row-major device arrays of the build's precision, rank 1 to 4.
using DeviceVector = Kokkos::View<real_t*, DeviceMemory>;
using DeviceMatrix = Kokkos::View<real_t**, Kokkos::LayoutRight, DeviceMemory>;
using DeviceCube = Kokkos::View<real_t***, Kokkos::LayoutRight, DeviceMemory>;
using DeviceQuad = Kokkos::View<real_t****, Kokkos::LayoutRight, DeviceMemory>;

// A View of rank 1-3 filled from row-major doubles, converted to the View's value type.
template <class View>
View upload(const std::string& label, const std::vector<double>& values, std::size_t n0, std::size_t n1 = 0,
            std::size_t n2 = 0) {
  View view;
  if constexpr (View::rank == 1) view = View(label, n0);
  if constexpr (View::rank == 2) view = View(label, n0, n1);
  if constexpr (View::rank == 3) view = View(label, n0, n1, n2);
  auto host = Kokkos::create_mirror_view(view);
  for (std::size_t i = 0; i < values.size(); ++i) host.data()[i] = typename View::value_type(values[i]);
  Kokkos::deep_copy(view, host);
  return view;
}

inline Kokkos::View<int*, DeviceMemory> upload_indices(const std::string& label, const std::vector<int>& values) {
  Kokkos::View<int*, DeviceMemory> view(label, values.size());
  auto host = Kokkos::create_mirror_view(view);
  std::copy(values.begin(), values.end(), host.data());
  Kokkos::deep_copy(view, host);
  return view;
}

// The View's values in memory order (row-major for LayoutRight), as doubles.
template <class View>
std::vector<double> download(const View& view) {
  auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), view);
  return std::vector<double>(host.data(), host.data() + host.size());
}

inline nn::Standardization<real_t> cast(const nn::Standardization<double>& s) {
  nn::Standardization<real_t> out;
  for (int d = 0; d < 3; ++d) {
    out.input_mean[d] = real_t(s.input_mean[d]);
    out.input_scale[d] = real_t(s.input_scale[d]);
    out.output_mean[d] = real_t(s.output_mean[d]);
    out.output_scale[d] = real_t(s.output_scale[d]);
  }
  return out;
}

inline nn::Mlp<real_t, DeviceMemory> device_mlp(const Model& model, const Kokkos::View<real_t*, DeviceMemory>& params) {
  nn::Mlp<real_t, DeviceMemory> mlp;
  mlp.layout = model.layout();
  mlp.standardization = cast(model.standardization);
  mlp.params = params;
  return mlp;
}

}  // namespace mpmrom::impl
