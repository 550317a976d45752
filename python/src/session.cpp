#include "session.hpp"

#include <map>
#include <memory>
#include <stdexcept>

#include "mpmrom/runtime.hpp"

namespace mpmrom::python {
namespace {

// Function-local statics: the module's only process-wide state, host objects (no Views).
std::unique_ptr<KokkosSession>& session() {
  static std::unique_ptr<KokkosSession> kokkos;
  return kokkos;
}
bool& finalized() {
  static bool done = false;
  return done;
}
std::map<const void*, std::function<void()>>& device_owners() {
  static std::map<const void*, std::function<void()>> owners;
  return owners;
}

}  // namespace

void initialize(int threads, int device) {
  if (finalized()) throw std::runtime_error("Kokkos was finalised at interpreter exit; it cannot start again");
  if (session())
    throw std::runtime_error(
        "Kokkos is already running: call mpmrom.initialize before anything else that runs (a command, a model)");
  session() = std::make_unique<KokkosSession>(threads, device);
}

void require_kokkos() {
  if (!session()) initialize(0, -1);
}

bool kokkos_running() { return session() != nullptr; }

void finalize() {
  // Each owner's free() leaves it unusable; copying first lets an owner unregister itself while freeing.
  const auto owners = device_owners();
  for (const auto& [key, free] : owners) free();
  device_owners().clear();
  session().reset();
  finalized() = true;
}

void register_device_owner(const void* key, std::function<void()> free) { device_owners()[key] = std::move(free); }
void unregister_device_owner(const void* key) { device_owners().erase(key); }

}  // namespace mpmrom::python
