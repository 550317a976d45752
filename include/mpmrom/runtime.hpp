// What this process runs on: backend, threads, device, versions. Every benchmark record and output file names it.
#pragma once

#include <string>

namespace mpmrom {

struct RuntimeInfo {
  std::string backend;         // Kokkos default execution space: Serial, OpenMP, Cuda
  int threads = 1;             // concurrency of the default host execution space
  std::string device;          // CPU model or GPU name
  std::string kokkos_version;  // major.minor.patch
  std::string precision;       // float or double
  std::string version;         // mpmrom version
  std::string git_commit;      // commit the binary was built from
};

// Kokkos for the lifetime of this object: threads <= 0 leaves Kokkos' default (OMP_NUM_THREADS); device < 0 takes
// GPU local_rank modulo the host's GPUs (the processes of one host, under MPI, share them round-robin).
class KokkosSession {
 public:
  explicit KokkosSession(int threads = 0, int device = -1, int local_rank = 0);
  ~KokkosSession();
  KokkosSession(const KokkosSession&) = delete;
  KokkosSession& operator=(const KokkosSession&) = delete;
};

// Requires Kokkos to be initialised.
RuntimeInfo runtime_info();

const char* git_commit();  // defined in the generated git_commit.cpp

}  // namespace mpmrom
