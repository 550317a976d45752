// Launch policies whose functor travels as a kernel argument. Kokkos's CUDA backend copies a functor larger than 512
// bytes to the GPU's constant memory instead, and first waits for the previous such kernel to finish: a host round
// trip per launch, which a short kernel (a small batch, a 10^5-particle FOM step) pays in full. Arguments hold up to
// 4 KB; host backends ignore the hint.
#pragma once

#include <Kokkos_Core.hpp>

namespace mpmrom {

using LightWeight = Kokkos::Experimental::WorkItemProperty::HintLightWeight_t;

}  // namespace mpmrom
