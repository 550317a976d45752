// HDF5 inputs: the same bytes are offered to every loader (snapshot, model, reduced-model file). Each must load a
// consistent object or raise its one-line error (std::exception); it must never crash, read out of bounds, or
// allocate what the file's claimed sizes ask for before checking them.
#include <fcntl.h>
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "mpmrom/model.hpp"
#include "rom/rom_file.hpp"
#include "mpmrom/snapshot.hpp"

namespace {

// Opens the file at descriptor 1000 or the first free one above: the number is part of the loaders' path
// (/proc/self/fd/N) and must not depend on the descriptors the process inherited.
int open_high(const std::string& name) {
  const int fd = ::open(name.c_str(), O_RDWR | O_CREAT | O_TRUNC, 0600);
  if (fd < 0) return fd;
  const int high = ::fcntl(fd, F_DUPFD, 1000);
  ::close(fd);
  return high;
}

// One file per fuzzing process (parallel -jobs share the directory), removed at exit.
struct InputFile {
  std::string name = "/tmp/mpmrom_fuzz_" + std::to_string(::getpid()) + ".h5";
  int fd = open_high(name);
  ~InputFile() { std::remove(name.c_str()); }
};

// The loaders open it through its descriptor, a name alike in every run: the process id in the name reached the
// loaders' messages, and runs from the same seed went different ways.
const std::string& input_path() {
  static const InputFile file;
  static const std::string path = "/proc/self/fd/" + std::to_string(file.fd);
  if (file.fd < 0) {
    std::perror(("fuzz_hdf5: " + file.name).c_str());
    std::abort();
  }
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

// Built in, so that every run (CI, campaigns, reproducing a crash by hand) gets them; ASAN_OPTIONS still overrides.
// Leaks are not checked (libhdf5 leaks on some failed opens). A damaged file can make libhdf5 ask for gigabytes to
// exabytes of metadata cache, which a normal build's malloc refuses or grants and HDF5 then reports in one line:
// here allocations above 2 GB fail too rather than abort the fuzzer. libhdf5's own out-of-bounds memcpy calls on
// damaged files (upstream, fuzz/libhdf5.supp) are suppressed; mpmrom's code stays fully checked.
extern "C" const char* __asan_default_options() {
  return "detect_leaks=0:allocator_may_return_null=1:max_allocation_size_mb=2048:suppressions='" MPMROM_FUZZ_DIR
         "/libhdf5.supp'";
}

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
  return 0;
}
