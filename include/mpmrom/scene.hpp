// A scene: bodies, material, grid, boundary conditions, forces, output schedule and parameter design, read from a TOML
// file (docs/scene_format.md). Everything in SI units. Parameters ("$name" in the file) are substituted on load.
#pragma once

#include <array>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace mpmrom {

using Vec3d = std::array<double, 3>;

struct AxisBox {
  Vec3d lo{}, hi{};
  bool contains(const Vec3d& p) const {
    for (int d = 0; d < 3; ++d)
      if (p[d] < lo[d] || p[d] > hi[d]) return false;
    return true;
  }
};

enum class ShapeKind { Box, Cylinder, Sphere };
enum class SamplingKind { Lattice, PoissonDisk, Explicit };

struct BodySpec {
  std::string name;
  ShapeKind shape = ShapeKind::Box;
  Vec3d center{};
  Vec3d half_extents{};  // box
  double radius = 0;     // cylinder (axis z) and sphere
  double height = 0;     // cylinder
  SamplingKind sampling = SamplingKind::Lattice;
  long count = 0;             // exact number of points (lattice spacing searched for it), or 0 to use spacing
  double spacing = 0;         // lattice spacing or Poisson-disk radius
  unsigned seed = 1;          // Poisson-disk sampling
  std::vector<Vec3d> points;  // explicit sampling: offsets from the center, each inside the shape
  Vec3d velocity{};           // initial velocity
  Vec3d angular_velocity{};   // initial spin about the body's center (rad/s)
};

enum class ElasticModelKind { NeoHookean, FixedCorotated };

struct MaterialSpec {
  ElasticModelKind model = ElasticModelKind::FixedCorotated;
  double youngs_modulus = 0;  // Pa
  double poisson_ratio = 0;
  double density = 0;  // kg/m^3
};

enum class ContactKind { Sticky, Slip, Separate };

// Grid nodes inside `region` (current configuration) get `velocity` during [start, end).
struct DirichletSpec {
  AxisBox region;
  Vec3d velocity{};
  double start = 0, end = 1e300;
};

// A total force (N) shared by the points that lie in `region` in the reference configuration, in proportion to their
// mass, applied during [start, end).
struct ForceSpec {
  AxisBox region;
  Vec3d force{};
  double start = 0, end = 1e300;
};

struct GroundSpec {
  bool enabled = false;
  double height = 0;
  ContactKind contact = ContactKind::Separate;
};

enum class TransferKind { APIC, PIC };

struct ParameterDesign {
  std::vector<std::string> names;           // alphabetical (TOML tables keep no order)
  std::vector<std::vector<double>> levels;  // levels per name (full factorial), or
  std::vector<std::vector<double>> runs;    // explicit runs (one value per name)
  std::vector<int> test_runs;               // indices of runs in the test split
  // Every run of the design, one value per name; full factorial varies the last name fastest.
  std::vector<std::vector<double>> all_runs() const;
};

struct Scene {
  std::string name;
  std::string source_text;  // the file as read
  std::string source_path;
  std::map<std::string, double> parameters;  // values in effect for this run
  MaterialSpec material;
  std::vector<BodySpec> bodies;
  AxisBox domain;  // the grid covers this box
  double dx = 0;
  ContactKind walls = ContactKind::Separate;
  GroundSpec ground;
  Vec3d gravity{};
  std::vector<DirichletSpec> dirichlet;
  std::vector<ForceSpec> forces;
  TransferKind transfer = TransferKind::APIC;
  double end_time = 0;
  int num_outputs = 1;  // output times are end_time * k / num_outputs, k = 0..num_outputs
  double cfl = 0.3;
  double time_step = 0;       // [time] dt: a fixed (longest) step instead of the CFL step; 0: from cfl
  double max_cfl = 0;         // safeguard: sub-step any step whose CFL number exceeds this; 0: off
  double energy_growth = 10;  // stop when energy exceeds this times (initial energy + work put in); 0: off
  ParameterDesign design;
};

// Reads and validates a scene. `overrides` are "key=value": a bare key sets a parameter, a dotted key
// (e.g. material.youngs_modulus) sets that entry of the file. Throws std::runtime_error with one line on bad input.
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides = {});

// The same from text already in memory; `label` names it in error messages.
Scene parse_scene(const std::string& text, const std::string& label, const std::vector<std::string>& overrides = {});

// The scene with more "key=value" overrides (as load_scene's) applied on top of it, keeping its parameter values.
Scene override_scene(const Scene& scene, const std::vector<std::string>& overrides);

// The scene at `factor` times its resolution: grid spacing dx / factor and each body's lattice or Poisson-disk spacing
// divided by factor (about factor^3 as many points), with the same parameter values. Its source_text reproduces it.
// Throws std::runtime_error for bodies given by explicit points, which have no resolution to change.
Scene refine_scene(const Scene& scene, double factor);

// The same scene with its parameters set to one run of the design (values in design.names order).
Scene scene_for_run(const std::string& path, const std::vector<std::string>& names, const std::vector<double>& values);

// A scene file read and parsed once, for many runs' parameter values (a batch of rollouts): run() is
// scene_for_run without reading and parsing the file again.
class SceneRuns {
 public:
  explicit SceneRuns(const std::string& path);
  Scene run(const std::vector<std::string>& names, const std::vector<double>& values) const;

 private:
  struct Parsed;
  std::shared_ptr<const Parsed> parsed_;
};

}  // namespace mpmrom
