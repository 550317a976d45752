#include "io/atomic_file.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <system_error>
#include <utility>

namespace mpmrom {
namespace {

// Data reaches the disk before the rename does, so after a power loss the final name holds the old or the new content.
void sync_to_disk(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0 || ::fsync(fd) != 0) {
    const int error = errno;
    if (fd >= 0) ::close(fd);
    throw std::runtime_error("cannot flush '" + path + "' to disk: " + std::strerror(error));
  }
  ::close(fd);
}

}  // namespace

AtomicFile::AtomicFile(std::string final_path)
    : final_path_(std::move(final_path)), temporary_path_(final_path_ + ".tmp." + std::to_string(::getpid())) {
  // Said plainly here rather than as a library's errno report when the temporary cannot be created.
  const std::filesystem::path directory = std::filesystem::path(final_path_).parent_path();
  std::error_code error;
  if (!directory.empty() && !std::filesystem::is_directory(directory, error))
    throw std::runtime_error("cannot write '" + final_path_ + "': there is no directory '" + directory.string() + "'");
}

void require_writable_output(const std::string& path) {
  const AtomicFile probe(path);  // checks the directory
  const std::filesystem::path directory = std::filesystem::path(path).parent_path();
  std::error_code error;
  if (std::filesystem::is_directory(path, error))
    throw std::runtime_error("cannot write '" + path + "': it is a directory");
  if (::access(directory.empty() ? "." : directory.c_str(), W_OK) != 0)
    throw std::runtime_error("cannot write '" + path + "': " + std::strerror(errno));
}

AtomicFile::~AtomicFile() {
  if (committed_) return;
  std::error_code ignored;  // a destructor cannot report, and a temporary left behind harms nothing
  std::filesystem::remove(temporary_path_, ignored);
}

void AtomicFile::commit() { commit_to(final_path_); }

void AtomicFile::commit_to(const std::string& path) {
  if (committed_) throw std::logic_error("'" + final_path_ + "' was already committed");
  sync_to_disk(temporary_path_);
  std::error_code error;
  std::filesystem::rename(temporary_path_, path, error);
  if (error) throw std::runtime_error("cannot move '" + temporary_path_ + "' to '" + path + "': " + error.message());
  committed_ = true;
}

void write_file_atomically(const std::string& path, const std::string& contents) {
  AtomicFile file(path);
  std::ofstream out(file.temporary_path(), std::ios::binary | std::ios::trunc);
  out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
  out.close();
  if (!out) throw std::runtime_error("cannot write '" + file.temporary_path() + "': " + std::strerror(errno));
  file.commit();
}

}  // namespace mpmrom
