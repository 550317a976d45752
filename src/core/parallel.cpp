#include "core/parallel.hpp"

#include <algorithm>
#include <climits>
#include <cstdint>
#include <cstdlib>
#include <stdexcept>

#if defined(MPMROM_HAVE_MPI)
#include <mpi.h>
#endif

namespace mpmrom::parallel {

#if defined(MPMROM_HAVE_MPI)
namespace {

bool mpi_running() {
  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  return initialized && !finalized;
}

void check(int status, const char* what) {
  if (status != MPI_SUCCESS) throw std::runtime_error(std::string("MPI: ") + what + " failed");
}

int to_int_count(std::size_t count) {
  if (count > std::size_t(INT_MAX)) throw std::runtime_error("MPI: a message of more than 2^31 elements");
  return int(count);
}

}  // namespace

bool built_with_mpi() { return true; }

Session::Session(int& argc, char**& argv) {
  if (!mpi_running()) check(MPI_Init(&argc, &argv), "MPI_Init");
  // Errors come back as return codes, which check() turns into exceptions with one line each.
  MPI_Comm_set_errhandler(MPI_COMM_WORLD, MPI_ERRORS_RETURN);
}
Session::~Session() {
  if (mpi_running()) MPI_Finalize();
}

Communicator Communicator::world() {
  if (!mpi_running()) return self();
  int rank = 0, size = 1;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return Communicator(true, rank, size);
}

#define MPMROM_COMM (world_ ? MPI_COMM_WORLD : MPI_COMM_SELF)

int Communicator::local_rank() const {
  if (!world_) return 0;
  MPI_Comm host;
  check(MPI_Comm_split_type(MPI_COMM_WORLD, MPI_COMM_TYPE_SHARED, rank_, MPI_INFO_NULL, &host), "host split");
  int rank = 0;
  MPI_Comm_rank(host, &rank);
  MPI_Comm_free(&host);
  return rank;
}

void Communicator::barrier() const {
  if (world_) check(MPI_Barrier(MPMROM_COMM), "MPI_Barrier");
}
void Communicator::sum(double* values, std::size_t count) const {
  if (world_) check(MPI_Allreduce(MPI_IN_PLACE, values, to_int_count(count), MPI_DOUBLE, MPI_SUM, MPMROM_COMM), "sum");
}
void Communicator::sum(float* values, std::size_t count) const {
  if (world_) check(MPI_Allreduce(MPI_IN_PLACE, values, to_int_count(count), MPI_FLOAT, MPI_SUM, MPMROM_COMM), "sum");
}
void Communicator::max(double* values, std::size_t count) const {
  if (world_) check(MPI_Allreduce(MPI_IN_PLACE, values, to_int_count(count), MPI_DOUBLE, MPI_MAX, MPMROM_COMM), "max");
}
double Communicator::max(double value) const {
  max(&value, 1);
  return value;
}
double Communicator::min(double value) const {
  if (world_) check(MPI_Allreduce(MPI_IN_PLACE, &value, 1, MPI_DOUBLE, MPI_MIN, MPMROM_COMM), "min");
  return value;
}

std::vector<std::string> Communicator::gather(const std::string& bytes, int root) const {
  if (!world_) return {bytes};
  const int count = to_int_count(bytes.size());
  std::vector<int> counts(rank_ == root ? std::size_t(size_) : 0), offsets(counts.size(), 0);
  check(MPI_Gather(&count, 1, MPI_INT, counts.data(), 1, MPI_INT, root, MPMROM_COMM), "gather sizes");
  std::size_t total = 0;
  for (std::size_t r = 0; r < counts.size(); ++r) {
    if (total > std::size_t(INT_MAX)) throw std::runtime_error("MPI: gathering more than 2 GB at one rank");
    offsets[r] = int(total);
    total += std::size_t(counts[r]);
  }
  std::string all(total, '\0');
  check(MPI_Gatherv(bytes.data(), count, MPI_BYTE, all.data(), counts.data(), offsets.data(), MPI_BYTE, root,
                    MPMROM_COMM),
        "gather");
  std::vector<std::string> parts;
  for (std::size_t r = 0; r < counts.size(); ++r) parts.push_back(all.substr(std::size_t(offsets[r]), counts[r]));
  return parts;
}

void Communicator::broadcast(std::string& bytes, int root) const {
  if (!world_) return;
  std::uint64_t size = bytes.size();
  check(MPI_Bcast(&size, 1, MPI_UINT64_T, root, MPMROM_COMM), "broadcast size");
  bytes.resize(std::size_t(size));
  check(MPI_Bcast(bytes.data(), to_int_count(bytes.size()), MPI_BYTE, root, MPMROM_COMM), "broadcast");
}

void Communicator::abort(int status) const {
  if (world_ && size_ > 1) MPI_Abort(MPI_COMM_WORLD, status);
  std::exit(status);
}

#undef MPMROM_COMM

#else  // no MPI: one process

bool built_with_mpi() { return false; }
Session::Session(int&, char**&) {}
Session::~Session() = default;
Communicator Communicator::world() { return self(); }
int Communicator::local_rank() const { return 0; }
void Communicator::barrier() const {}
void Communicator::sum(double*, std::size_t) const {}
void Communicator::sum(float*, std::size_t) const {}
void Communicator::max(double*, std::size_t) const {}
double Communicator::max(double value) const { return value; }
double Communicator::min(double value) const { return value; }
std::vector<std::string> Communicator::gather(const std::string& bytes, int) const { return {bytes}; }
void Communicator::broadcast(std::string&, int) const {}
void Communicator::abort(int status) const { std::exit(status); }

#endif

Communicator Communicator::self() { return Communicator(false, 0, 1); }

bool Communicator::any(bool value) const { return max(value ? 1.0 : 0.0) > 0; }

Share share_of(std::size_t count, int rank, int size) {
  const std::size_t base = count / std::size_t(size), extra = count % std::size_t(size);
  const std::size_t r = std::size_t(rank);
  const std::size_t begin = r * base + std::min(r, extra);
  return {begin, begin + base + (r < extra ? 1 : 0)};
}

}  // namespace mpmrom::parallel
