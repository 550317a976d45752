// Scene files: any text must parse into a valid Scene or raise the parser's one-line error (std::exception).
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>

#include "mpmrom/scene.hpp"
#include "snapshots/simulate.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  try {
    const mpmrom::Scene scene = mpmrom::parse_scene(text, "fuzz");
    // A scene that parses must also give its design and its lattice size without failing.
    (void)mpmrom::sweep_runs(scene);
  } catch (const std::exception&) {
  }
  return 0;
}
