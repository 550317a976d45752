// Outputs appear whole or not at all: each is written under a temporary name next to its final path and renamed into
// place once complete, so a reader never sees half a file and a failed or killed run leaves nothing under the final
// name (a killed process cannot clean up, so its "<final>.tmp.<pid>" may remain beside it).
#pragma once

#include <string>

namespace mpmrom {

class AtomicFile {
 public:
  explicit AtomicFile(std::string final_path);
  ~AtomicFile();  // removes the temporary unless committed
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  const std::string& final_path() const { return final_path_; }
  const std::string& temporary_path() const { return temporary_path_; }  // "<final>.tmp.<pid>": write the content here
  bool committed() const { return committed_; }

  // Flushes the temporary to disk and renames it onto the final path, replacing any file there.
  void commit();
  // The same onto another path (a run that failed keeps its output under a name that says so).
  void commit_to(const std::string& path);

 private:
  std::string final_path_;
  std::string temporary_path_;
  bool committed_ = false;
};

void write_file_atomically(const std::string& path, const std::string& contents);

// Throws the error AtomicFile(path) would meet later (no such directory, not writable, a directory in the way): for
// commands that write their output only after minutes of work.
void require_writable_output(const std::string& path);

}  // namespace mpmrom
