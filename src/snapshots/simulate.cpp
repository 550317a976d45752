#include "snapshots/simulate.hpp"

#include <Kokkos_Core.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "io/atomic_file.hpp"
#include "core/parallel.hpp"
#include "core/timing.hpp"
#include "mpmrom/snapshot.hpp"
#include "snapshots/snapshot_writer.hpp"

namespace mpmrom {
namespace {

// 1.1 rather than 1.1000000000000001: the fewest significant digits that read back as the same double.
std::string shortest_round_trip(double value) {
  char text[32];
  for (int digits = 15; digits < 17; ++digits) {
    std::snprintf(text, sizeof text, "%.*g", digits, value);
    if (std::strtod(text, nullptr) == value) return text;
  }
  std::snprintf(text, sizeof text, "%.17g", value);
  return text;
}

// Whether `path` holds this run, finished. Throws if it holds another scene's run: resuming must not mix sweeps.
bool finished_before(const std::string& path, const Scene& run_scene) {
  std::error_code error;
  if (!std::filesystem::exists(path, error)) return false;
  SnapshotHeader header;
  try {
    header = read_snapshot_header(path);
  } catch (const std::exception&) {
    return false;  // damaged or incomplete: simulated again and replaced
  }
  if (header.scene_text != run_scene.source_text)
    throw std::runtime_error(path +
                             ": holds a run of another scene or parameters; remove it or sweep without --resume");
  return true;
}

}  // namespace

void advance_through_outputs(FomSolver& solver, const Scene& scene, const FrameCallback& on_frame) {
  for (int k = 0; k <= scene.num_outputs; ++k) {
    const auto step_start = SteadyClock::now();
    solver.advance_to(scene.end_time * k / scene.num_outputs);
    Kokkos::fence();
    const double step_seconds = seconds_since(step_start);
    on_frame(solver.frame(), step_seconds);
  }
}

void simulate(const Scene& scene, const std::string& out_path, P2GStrategy strategy,
              const SimulationCallback& progress) {
  const auto start = SteadyClock::now();
  FomSolver solver(scene, strategy);
  SnapshotHeader header;
  header.scene_name = scene.name;
  header.scene_text = scene.source_text;
  for (const auto& [name, value] : scene.parameters) header.parameters.emplace_back(name, value);
  header.dx = scene.dx;
  std::vector<real_t> X, mass, volume;
  solver.reference(X, mass, volume);
  SnapshotWriter writer(out_path, header, solver.num_particles(), X.data(), mass.data(), volume.data());
  const int num_frames = scene.num_outputs + 1;
  int written = 0;
  double step_seconds = 0;
  try {
    advance_through_outputs(solver, scene, [&](const ParticleFrame& f, double seconds) {
      step_seconds += seconds;
      writer.append(f.time, f.x.data(), f.v.data(), f.F.data(), f.C.data());
      ++written;
      if (progress)
        progress({written, num_frames, solver.time(), solver.steps(), solver.num_particles(), seconds_since(start),
                  step_seconds});
    });
  } catch (const SimulationFailure& failure) {
    // The frames before the failure stay readable (ParaView, and the cause) under a name no reader mistakes for a
    // finished run.
    const std::string kept = writer.commit_failed(failure.what());
    throw SimulationFailure(failure.cause(), failure.step(), failure.time(),
                            failure.detail() + "; the " + std::to_string(written) + " frames before it are in " + kept);
  }
  writer.commit();
}

std::vector<SweepRun> sweep_runs(const Scene& scene) {
  const auto runs = scene.design.all_runs();
  if (runs.empty()) throw std::runtime_error("scene " + scene.source_path + " has no [design] to sweep");
  std::vector<SweepRun> result;
  for (std::size_t r = 0; r < runs.size(); ++r) {
    std::string number = std::to_string(r);
    number.insert(0, number.size() < 3 ? 3 - number.size() : 0, '0');
    SweepRun run;
    run.values = runs[r];
    run.file = "runs/run_" + number + ".h5";
    for (int t : scene.design.test_runs) run.test = run.test || static_cast<std::size_t>(t) == r;
    result.push_back(run);
  }
  return result;
}

void sweep(const std::string& scene_path, const std::string& out_dir, P2GStrategy strategy,
           const SweepRunCallback& on_run, const SimulationCallback& progress, bool resume,
           const parallel::Communicator& comm) {
  const Scene scene = load_scene(scene_path);
  const auto runs = sweep_runs(scene);
  std::error_code error;
  std::filesystem::create_directories(std::filesystem::path(out_dir) / "runs", error);
  if (error) throw std::runtime_error("cannot create " + out_dir + "/runs: " + error.message());
  if (resume && comm.is_root()) {
    // Temporary files of the run a killed sweep was in (AtomicFile's NAME.tmp.PID): never complete, never read.
    for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(out_dir) / "runs", error))
      if (entry.path().filename().string().find(".tmp.") != std::string::npos)
        std::filesystem::remove(entry.path(), error);
  }
  comm.barrier();  // no rank starts a run while rank 0 still removes temporary files
  // Runs dealt round-robin: neighbouring runs of a design often cost alike.
  for (std::size_t r = std::size_t(comm.rank()); r < runs.size(); r += std::size_t(comm.size())) {
    const Scene run_scene = scene_for_run(scene_path, scene.design.names, runs[r].values);
    const std::string path = (std::filesystem::path(out_dir) / runs[r].file).string();
    const bool reused = resume && finished_before(path, run_scene);
    if (on_run) on_run(r, runs.size(), runs[r], reused);
    if (!reused) simulate(run_scene, path, strategy, progress);
  }
  comm.barrier();  // every run is written before the design names it
  if (!comm.is_root()) return;
  std::ostringstream csv;
  for (const auto& name : scene.design.names) csv << name << ",";
  csv << "split,file\n";
  for (const auto& run : runs) {
    for (double v : run.values) csv << shortest_round_trip(v) << ",";
    csv << (run.test ? "test" : "train") << "," << run.file << "\n";
  }
  write_file_atomically((std::filesystem::path(out_dir) / "design.csv").string(), csv.str());
}

}  // namespace mpmrom
