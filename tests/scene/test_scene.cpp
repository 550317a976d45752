// Scene files: parameters and overrides, the design, and one clear error for each kind of bad input.
#include <cmath>
#include <stdexcept>

#include "backends.hpp"
#include "fixtures.hpp"
#include "scene/sampling.hpp"
#include "mpmrom/scene.hpp"

namespace mpmrom::test {
namespace {

const std::string kValid = fixture_text("box_under_force.toml");

// The error message of parsing `text`, or "" if it parsed.
std::string error_of(const std::string& text, const std::vector<std::string>& overrides = {}) {
  try {
    parse_scene(text, "scene.toml", overrides);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  return text.replace(at, from.size(), to);
}

TEST(Scene, ParametersOverridesAndDesign) {
  const Scene scene = parse_scene(kValid, "scene.toml");
  ASSERT_EQ(scene.forces.size(), 1u);
  // theta = 90 deg, phi = 0: a horizontal push along +y of the parameter's magnitude.
  EXPECT_NEAR(scene.forces[0].force[0], 0.0, 1e-15);
  EXPECT_NEAR(scene.forces[0].force[1], 2.0, 1e-15);
  EXPECT_EQ(scene.design.all_runs().size(), 2u);
  EXPECT_EQ(scene.design.test_runs, std::vector<int>{1});
  const Scene changed = parse_scene(kValid, "scene.toml", {"force=3.5", "material.density=500"});
  EXPECT_NEAR(changed.forces[0].force[1], 3.5, 1e-15);
  EXPECT_EQ(changed.material.density, 500.0);
}

TEST(Scene, OverriddenEntriesAreStoredInTheSceneText) {
  const Scene changed = parse_scene(kValid, "scene.toml", {"body.0.spacing=0.04", "grid.dx=0.08"});
  EXPECT_EQ(changed.bodies[0].spacing, 0.04);
  EXPECT_EQ(changed.dx, 0.08);
  // the stored text alone reproduces the changed scene (snapshots keep only the text)
  const Scene again = parse_scene(changed.source_text, "stored");
  EXPECT_EQ(again.bodies[0].spacing, 0.04);
  EXPECT_EQ(again.dx, 0.08);
  EXPECT_NE(error_of(kValid, {"body.1.spacing=0.04"}).find("no table number 1"), std::string::npos);
}

TEST(Scene, RefinementScalesGridAndLattice) {
  const Scene scene = parse_scene(kValid, "scene.toml", {"force=3"});
  const Scene fine = refine_scene(scene, 2.0);
  EXPECT_DOUBLE_EQ(fine.dx, 0.05);
  // the grid keeps a node at the body's lower faces (-0.1) and covers the original domain
  for (int d = 0; d < 3; ++d) {
    EXPECT_LE(fine.domain.lo[d], scene.domain.lo[d]);
    EXPECT_GE(fine.domain.hi[d], scene.domain.hi[d]);
    const double cells = (-0.1 - fine.domain.lo[d]) / fine.dx;
    EXPECT_NEAR(cells, std::round(cells), 1e-9);
  }
  // coarsening keeps the 2-cell margin by growing the domain: 0.4-cell grid around a 0.2 box in [-1, 1]
  const Scene coarse = refine_scene(scene, 0.25);
  EXPECT_LE(coarse.domain.lo[0], -0.1 - 2 * coarse.dx);
  EXPECT_DOUBLE_EQ(fine.bodies[0].spacing, 0.025);
  EXPECT_EQ(fine.parameters.at("force"), 3.0);  // the run's values, not the file's defaults
  // a box aligned with its lattice: exactly 2^3 times the points, the same total mass
  const auto coarse_points = sample_scene(scene), fine_points = sample_scene(fine);
  EXPECT_EQ(fine_points.size(), 8 * coarse_points.size());
  double coarse_mass = 0, fine_mass = 0;
  for (double m : coarse_points.mass) coarse_mass += m;
  for (double m : fine_points.mass) fine_mass += m;
  EXPECT_NEAR(fine_mass, coarse_mass, 1e-12 * coarse_mass);
  const Scene again = parse_scene(fine.source_text, "stored", {"force=3"});
  EXPECT_DOUBLE_EQ(again.dx, fine.dx);
  EXPECT_DOUBLE_EQ(again.bodies[0].spacing, fine.bodies[0].spacing);
  // a body given by a count is refined through the spacing that count gives
  const Scene counted = parse_scene(replace(kValid, "spacing = 0.05", "count = 64"), "scene.toml");
  const Scene counted_fine = refine_scene(counted, 2.0);
  EXPECT_EQ(counted_fine.bodies[0].count, 0);
  EXPECT_EQ(sample_scene(counted_fine).size(), 512u);
  EXPECT_THROW(refine_scene(scene, 0.0), std::runtime_error);
}

TEST(Scene, BadInputGivesOneClearLine) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {replace(kValid, "density = 100.0", "density = 100.0\ndensty = 3"), "unknown key 'densty'"},
      {replace(kValid, "poisson_ratio = 0.3", "poisson_ratio = 0.5"), "poisson_ratio must lie in (-1, 0.5)"},
      {replace(kValid, "youngs_modulus = 1e4", "youngs_modulus = -1"), "youngs_modulus must be positive"},
      {replace(kValid, "youngs_modulus = 1e4", "youngs_modulus = nan"), "not finite"},
      {replace(kValid, "size = [0.2, 0.2, 0.2]", "size = [0.2, 0.0, 0.2]"), "box size must be positive"},
      {replace(kValid, "center = [0.0, 0.0, 0.0]", "center = [0.95, 0.0, 0.0]"), "must lie inside the grid"},
      {replace(kValid, "dx = 0.1", "dx = 0"), "dx must be positive"},
      {replace(kValid, "magnitude = \"$force\"", "magnitude = \"$forse\""), "unknown parameter '$forse'"},
      {replace(kValid, "spacing = 0.05", "spacing = \"fine\""), "must be a number"},
      {replace(kValid, "[time]", "[time\n"), "scene.toml:"},
      {replace(kValid, "test = [1]", "test = [2]"), "each test run index must be a whole number in [0, 1], not 2"},
      {replace(kValid, "shape = \"box\"", "shape = \"torus\""), "shape must be box, cylinder or sphere"},
  };
  for (const auto& [text, expected] : cases) {
    const std::string message = error_of(text);
    EXPECT_NE(message.find(expected), std::string::npos) << "expected '" << expected << "', got '" << message << "'";
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  EXPECT_NE(error_of(kValid, {"forse=1"}).find("no such parameter"), std::string::npos);
  EXPECT_NE(error_of(kValid, {"force=abc"}).find("not a finite number"), std::string::npos);
}

// Found by fuzzing: outputs = 2777777777 was converted to int unchecked (undefined behaviour). Every count, index and
// seed must be a whole number in its field's range before it is converted, however it arrives: a TOML integer, a
// float, a parameter, or a --set value.
TEST(Scene, CountsMustBeWholeNumbersInRange) {
  const std::string with_outputs = replace(kValid, "end_time = 0.1", "end_time = 0.1\noutputs = OUTPUTS");
  const auto outputs_error = [&](const std::string& outputs, const std::vector<std::string>& overrides = {}) {
    return error_of(replace(with_outputs, "OUTPUTS", outputs), overrides);
  };
  const std::string field = "scene scene.toml [time]: outputs must be a whole number in [1, 2147483647], not ";
  EXPECT_EQ(outputs_error("2777777777"), field + "2777777777");
  EXPECT_EQ(outputs_error("2.5"), field + "2.5");
  EXPECT_EQ(outputs_error("-3"), field + "-3");
  EXPECT_EQ(outputs_error("0"), field + "0");
  EXPECT_EQ(outputs_error("1e300"), field + "1e+300");
  // through a parameter, set in the file or by --set, and through a --set of the entry itself
  const std::string by_parameter = replace(with_outputs, "force = 2.0", "force = 2.0\nframes = 10");
  EXPECT_EQ(error_of(replace(by_parameter, "OUTPUTS", "\"$frames\""), {"frames=2.5"}), field + "2.5");
  EXPECT_EQ(error_of(replace(by_parameter, "OUTPUTS", "\"$frames\""), {"frames=2777777777"}), field + "2777777777");
  EXPECT_EQ(outputs_error("10", {"time.outputs=2777777777"}), field + "2777777777");
  EXPECT_EQ(outputs_error("10", {"time.outputs=0.5"}), field + "0.5");
  // whole numbers arrive as TOML integers, as floats and as parameters alike
  EXPECT_EQ(parse_scene(replace(with_outputs, "OUTPUTS", "10"), "scene.toml").num_outputs, 10);
  EXPECT_EQ(parse_scene(replace(with_outputs, "OUTPUTS", "10.0"), "scene.toml").num_outputs, 10);
  EXPECT_EQ(parse_scene(replace(by_parameter, "OUTPUTS", "\"$frames\""), "scene.toml", {"frames=12"}).num_outputs, 12);
  EXPECT_EQ(parse_scene(replace(with_outputs, "OUTPUTS", "10"), "scene.toml", {"time.outputs=7"}).num_outputs, 7);

  const std::string count = "scene scene.toml [[body]] 1: count must be a whole number in [0, 2000000000], not ";
  EXPECT_EQ(error_of(replace(kValid, "spacing = 0.05", "count = 1e19")), count + "1e+19");
  EXPECT_EQ(error_of(replace(kValid, "spacing = 0.05", "count = 64.5")), count + "64.5");
  EXPECT_EQ(error_of(kValid, {"body.0.count=-1"}), count + "-1");
  EXPECT_EQ(error_of(replace(kValid, "spacing = 0.05", "spacing = 0.05\nseed = -1")),
            "scene scene.toml [[body]] 1: seed must be a whole number in [0, 4294967295], not -1");
  EXPECT_EQ(error_of(replace(kValid, "test = [1]", "test = [1e30]")),
            "scene scene.toml [design]: each test run index must be a whole number in [0, 1], not 1e+30");
}

}  // namespace
}  // namespace mpmrom::test
