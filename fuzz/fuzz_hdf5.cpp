// HDF5 inputs: the same bytes are offered to every loader (snapshot, model, reduced-model file). Each must load a
// consistent object or raise its one-line error (std::exception); it must never crash, read out of bounds, or
// allocate what the file's claimed sizes ask for before checking them.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <string>

#include "model.hpp"
#include "rom_file.hpp"
#include "snapshot.hpp"

namespace {

// One file per fuzzing process (parallel -jobs share the directory).
const std::string& input_path() {
  static const std::string path = "/tmp/mpmrom_fuzz_" + std::to_string(::getpid()) + ".h5";
  return path;
}

template <class Load>
void try_load(Load&& load) {
  try {
    load();
  } catch (const std::exception&) {
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string& path = input_path();
  std::FILE* file = std::fopen(path.c_str(), "wb");
  if (file == nullptr) return 0;
  const bool written = std::fwrite(data, 1, size, file) == size;
  std::fclose(file);
  if (!written) return 0;
  try_load([&] { (void)mpmrom::read_snapshot(path); });
  try_load([&] { (void)mpmrom::load_model(path); });
  try_load([&] { (void)mpmrom::load_rom(path); });
  std::remove(path.c_str());
  return 0;
}
