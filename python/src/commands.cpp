// mpmrom's subcommands run in the Python process: the program's own parser and code (apps/mpmrom/program.hpp), its
// stdout captured and returned, its stderr lines handed to a Python callable, its failures raised as exceptions
// carrying the program's one line.
#include <nanobind/nanobind.h>
#include <nanobind/stl/string.h>
#include <nanobind/stl/vector.h>

#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "common.hpp"
#include "core/parallel.hpp"
#include "program.hpp"
#include "session.hpp"

namespace nb = nanobind;

namespace mpmrom::python {
namespace {

// A stream buffer that hands each complete line to a Python callable (taking the GIL for the call). An exception
// the callable raises is kept and raised once the command has finished.
class LineSink : public std::streambuf {
 public:
  explicit LineSink(nb::object callback) : callback_(std::move(callback)) {}
  // Whether the callable raised KeyboardInterrupt: the command stops at its next progress point.
  bool interrupted() const { return interrupted_; }
  // Hands over a last unterminated line, then raises what the callable raised.
  void finish() {
    flush_line();
    if (error_) std::rethrow_exception(error_);
  }

 protected:
  int overflow(int c) override {
    if (c == traits_type::eof()) return traits_type::not_eof(c);
    if (c == '\n')
      flush_line();
    else
      line_.push_back(static_cast<char>(c));
    return c;
  }

 private:
  void flush_line() {
    if (line_.empty()) return;
    nb::gil_scoped_acquire gil;
    if (!error_ && callback_.is_valid() && !callback_.is_none()) {
      try {
        callback_(line_);
      } catch (const nb::python_error& e) {
        interrupted_ = e.matches(PyExc_KeyboardInterrupt);  // Ctrl-C while the callback ran
        error_ = std::current_exception();
      } catch (...) {
        error_ = std::current_exception();
      }
    }
    line_.clear();
  }

  nb::object callback_;
  std::string line_;
  std::exception_ptr error_;
  bool interrupted_ = false;
};

// Ctrl-C during a command: at each progress point the command takes the interpreter's lock to run Python's signal
// handlers; one that raises (KeyboardInterrupt) stops the command, and run_command raises it once the command has
// unwound (its outputs are closed as on any error: nothing half-written is left).
class InterruptionCheck {
 public:
  explicit InterruptionCheck(const LineSink& sink) {
    cli::set_interruption_check([this, &sink] {
      if (sink.interrupted()) throw cli::Interrupted();
      nb::gil_scoped_acquire gil;
      if (PyErr_CheckSignals() == 0) return;
      raised_ = std::make_exception_ptr(nb::python_error());
      throw cli::Interrupted();
    });
  }
  ~InterruptionCheck() { cli::set_interruption_check({}); }
  InterruptionCheck(const InterruptionCheck&) = delete;
  InterruptionCheck& operator=(const InterruptionCheck&) = delete;

  // Raises what a signal handler raised, if one did (the interpreter's lock held).
  void finish() const {
    if (raised_) std::rethrow_exception(raised_);
  }

 private:
  std::exception_ptr raised_;
};

// Points a standard stream at another buffer for its lifetime.
class Redirect {
 public:
  Redirect(std::ostream& stream, std::streambuf* buffer) : stream_(stream), previous_(stream.rdbuf(buffer)) {}
  ~Redirect() { stream_.rdbuf(previous_); }
  Redirect(const Redirect&) = delete;
  Redirect& operator=(const Redirect&) = delete;

 private:
  std::ostream& stream_;
  std::streambuf* previous_;
};

std::string first_line(const std::string& text) {
  const auto end = text.find('\n');
  return end == std::string::npos ? text : text.substr(0, end);
}

// Every named option of `command` (positional arguments and --help left out).
nb::list command_options(const std::string& command) {
  cli::Program program;
  CLI::App* sub = nullptr;
  try {
    sub = program.app.get_subcommand(command);
  } catch (const CLI::OptionNotFound&) {
    throw nb::value_error(("no command '" + command + "'").c_str());
  }
  nb::list options;
  for (const CLI::Option* option : sub->get_options()) {
    if (option->get_lnames().empty() || option->get_lnames().front() == "help") continue;
    nb::dict entry;
    entry["name"] = option->get_lnames().front();
    entry["description"] = option->get_description();
    entry["type"] = option->get_type_name();
    entry["default"] = option->get_default_str();
    entry["kind"] = option->get_expected_max() == 0 ? "flag" : option->get_items_expected_max() > 1 ? "list" : "value";
    options.append(entry);
  }
  return options;
}

// Runs `mpmrom ARGS...`; returns what it printed on stdout (help text for --help).
std::string run_command(const std::vector<std::string>& args, nb::object log) {
  std::vector<std::string> storage{"mpmrom"};
  storage.insert(storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (auto& arg : storage) argv.push_back(arg.data());
  const int argc = static_cast<int>(argv.size());

  cli::Program program;
  std::ostringstream out;
  try {
    program.app.parse(argc, argv.data());
  } catch (const CLI::ParseError& e) {
    std::ostringstream err;
    if (program.app.exit(e, out, err) == 0) return out.str();  // --help, --version
    throw Error("mpmrom: error: " + first_line(err.str().empty() ? e.what() : err.str()));
  }
  if (program.threads != 0 || program.device >= 0)
    throw Error("mpmrom: error: --threads and --device are set once per process, by mpmrom.initialize()");
  require_kokkos();
  const auto& chosen = program.chosen();
  cli::set_verbosity(program.quiet     ? cli::Verbosity::quiet
                     : program.verbose ? cli::Verbosity::verbose
                                       : cli::Verbosity::normal);
  LineSink sink(std::move(log));
  InterruptionCheck interruption(sink);
  int status = 0;
  cli::Failure failure;
  {
    Redirect capture_out(std::cout, out.rdbuf());
    Redirect capture_err(std::cerr, &sink);
    nb::gil_scoped_release no_gil;  // the work runs without the interpreter; progress lines take it back
    try {
      status = chosen.run(cli::Context{program.quiet, parallel::Communicator::world(), argc, argv.data()});
    } catch (const cli::Interrupted&) {
      status = -1;  // raised below: the signal handler's exception, or the callback's
    } catch (...) {
      failure = cli::describe_failure(std::current_exception());
      status = failure.status;
    }
  }
  interruption.finish();
  sink.finish();
  if (!failure.line.empty()) {
    const auto line = first_line(failure.line);
    if (failure.status == 3) throw SimulationFailed(line);
    throw Error(line);
  }
  if (status != 0) throw Error("mpmrom: error: " + args.front() + " ended with status " + std::to_string(status));
  return out.str();
}

}  // namespace

void bind_commands(nb::module_& m) {
  m.def("command_options", &command_options, nb::arg("command"),
        "The options of a subcommand as its parser declares them: [{name, description, type, default, kind}], kind "
        "'flag', 'value' or 'list' (the stub generator of python/stubgen_commands.py reads them).");
  m.def("run_command", &run_command, nb::arg("args"), nb::arg("log").none() = nb::none(),
        "Runs `mpmrom ARGS...` in this process and returns what it printed on stdout. Each line it prints on stderr "
        "(progress, warnings) goes to log(line). Raises mpmrom.Error (mpmrom.SimulationFailed for a failed "
        "simulation) with the program's one-line message.");
}

}  // namespace mpmrom::python
