// The processes a command's work is spread over. In a build with -DMPMROM_ENABLE_MPI=ON started under mpirun, the
// world is MPI_COMM_WORLD; otherwise (no MPI in the build, or MPI not initialised) it is this process alone and every
// operation below is a local no-op. Only src/core/parallel.cpp sees MPI, so the rest of the library builds the same
// either way.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace mpmrom::parallel {

// True when the library was built with MPI.
bool built_with_mpi();

// MPI for the lifetime of this object (MPI_Init / MPI_Finalize; nothing without MPI). Create it before Kokkos.
class Session {
 public:
  Session(int& argc, char**& argv);
  ~Session();
  Session(const Session&) = delete;
  Session& operator=(const Session&) = delete;
};

// Collective operations: every rank of the communicator calls them in the same order with the same sizes.
class Communicator {
 public:
  static Communicator world();  // every process of the run (this process alone without MPI)
  static Communicator self();   // this process alone
  int rank() const { return rank_; }
  int size() const { return size_; }
  bool is_root() const { return rank_ == 0; }
  // Rank among the processes on this host: which GPU a rank takes.
  int local_rank() const;

  void barrier() const;
  // In place, over every rank: element-wise sums (MPI_Allreduce with MPI_SUM) or maxima.
  void sum(double* values, std::size_t count) const;
  void sum(float* values, std::size_t count) const;
  void max(double* values, std::size_t count) const;
  double max(double value) const;
  double min(double value) const;
  bool any(bool value) const;
  // Each rank's bytes, in rank order, at root (empty elsewhere).
  std::vector<std::string> gather(const std::string& bytes, int root = 0) const;
  // root's bytes on every rank.
  void broadcast(std::string& bytes, int root = 0) const;
  // Ends every process of the run with this exit status (one rank's error must not leave the others waiting).
  [[noreturn]] void abort(int status) const;

 private:
  Communicator(bool world, int rank, int size) : world_(world), rank_(rank), size_(size) {}
  [[maybe_unused]] bool world_;  // read only by the MPI build
  int rank_, size_;
};

// The contiguous share [begin, end) of count items that rank takes of size ranks (the first count % size ranks take
// one more).
struct Share {
  std::size_t begin = 0, end = 0;
};
Share share_of(std::size_t count, int rank, int size);

}  // namespace mpmrom::parallel
