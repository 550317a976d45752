// Kokkos in a Python process: initialised once, on the first call that needs it (or by mpmrom.initialize), and
// finalised at interpreter exit after the live rollout batches have freed their device memory.
#pragma once

#include <functional>

namespace mpmrom::python {

// Starts Kokkos with these settings (threads <= 0: OMP_NUM_THREADS or every core; device < 0: GPU 0). Throws
// std::runtime_error when Kokkos is already running or was finalised.
void initialize(int threads, int device);
// Starts Kokkos with its defaults unless it runs; throws std::runtime_error after finalize().
void require_kokkos();
bool kokkos_running();
// Frees what every registered owner holds on the device (Kokkos Views must go before Kokkos), then finalises Kokkos.
void finalize();

// An object holding device memory registers a function that frees it, under a key it removes when it goes.
void register_device_owner(const void* key, std::function<void()> free);
void unregister_device_owner(const void* key);

}  // namespace mpmrom::python
