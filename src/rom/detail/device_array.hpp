// A device View's copy handed out as the public DeviceArray (rollout_batch.hpp), for DLPack consumers.
#pragma once

#include <Kokkos_Core.hpp>

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <type_traits>

#include "mpmrom/rollout_batch.hpp"

namespace mpmrom::impl {

// A contiguous copy of `view` (rank 2, LayoutRight) in its own memory space, owned by the DeviceArray.
template <class View>
DeviceArray device_snapshot(const View& view) {
  static_assert(View::rank == 2 && std::is_same_v<typename View::array_layout, Kokkos::LayoutRight>);
  using MemorySpace = typename View::memory_space;
  using Copy = Kokkos::View<typename View::non_const_value_type**, Kokkos::LayoutRight, MemorySpace>;
  auto copy = std::make_shared<Copy>(Kokkos::view_alloc(Kokkos::WithoutInitializing, view.label() + "_copy"),
                                     view.extent(0), view.extent(1));
  Kokkos::deep_copy(*copy, view);
  DeviceArray array;
  array.data = copy->data();
  array.shape = {std::int64_t(view.extent(0)), std::int64_t(view.extent(1))};
  array.bits = int(8 * sizeof(typename View::value_type));
  if constexpr (!Kokkos::SpaceAccessibility<Kokkos::HostSpace, MemorySpace>::accessible) {
#if defined(KOKKOS_ENABLE_CUDA)
    array.dlpack_device_type = 2;  // kDLCUDA
    array.device_id = Kokkos::Cuda().cuda_device();
#else
    throw std::runtime_error("device arrays: this build's device memory has no DLPack device type here");
#endif
  }
  array.owner = std::move(copy);
  return array;
}

}  // namespace mpmrom::impl
