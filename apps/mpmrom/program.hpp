// The mpmrom program as a library: its options and subcommands, and the one line and exit status each failure ends
// with. The executable (main.cpp) and the Python module (python/src/commands.cpp) both run it.
#pragma once

#include <CLI/CLI.hpp>

#include <exception>
#include <string>

#include "command.hpp"

namespace mpmrom::cli {

// Every global option and subcommand, parsed into its members: construct in place, parse, then run chosen().
class Program {
 public:
  Program();
  Program(const Program&) = delete;
  Program& operator=(const Program&) = delete;

  CLI::App app{"mpmrom: material point method and its neural reduced-order model, on Kokkos"};
  int threads = 0;
  int device = -1;
  bool quiet = false;
  bool verbose = false;

  // The subcommand parse() chose (CLI11 requires exactly one).
  const Command& chosen() const;

 private:
  Commands commands_;
};

// How a command that threw ends: the exit status (3 a failed simulation, 1 anything else) and its line on stderr,
// newline-terminated ("mpmrom: error: ...", or the out-of-memory line naming the allocation).
struct Failure {
  int status = 1;
  std::string line;
};
Failure describe_failure(const std::exception_ptr& error);

}  // namespace mpmrom::cli
