// The pipeline's choices that do not need a trained model: which training runs are held out for validation, the
// Pareto front of cost against error, network names, the methods' names and the charts' files.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include "backends.hpp"
#include "fixtures.hpp"
#include "studies/charts.hpp"
#include "studies/detail/format.hpp"
#include "studies/detail/pipeline_report.hpp"
#include "studies/pipeline.hpp"
#include "mpmrom/scene.hpp"

namespace mpmrom::test {
namespace {

TEST(PipelineValidation, HoldsOutInteriorTrainingRunsNeverTestRuns) {
  const Scene scene = fixture_scene("three_parameter_design.toml");
  const auto held_out = validation_runs(scene, -1);
  // 22 training runs: (22 + 3) / 6 = 4 held out
  ASSERT_EQ(held_out.size(), 4u);
  // runs 12 = (1, 1, 0) and 14 = (1, 1, 2) are the only training runs with two interior levels; then two of the 12
  // runs with one, from the middles of equal shares: positions 3 and 9 of {1, 3, 5, 7, 9, 11, 15, 17, 19, 21, 23, 25}
  EXPECT_EQ(held_out, (std::vector<std::size_t>{7, 12, 14, 21}));
  for (std::size_t r : held_out)
    for (int t : scene.design.test_runs) EXPECT_NE(r, std::size_t(t));
  EXPECT_EQ(validation_runs(scene, 1), std::vector<std::size_t>{14});  // the middle of {12, 14}
  EXPECT_THROW(validation_runs(scene, 22), std::runtime_error);        // nothing would be left to train on
}

TEST(PipelineFront, KeepsOnlyConfigurationsNothingCheaperBeats) {
  const double inf = std::numeric_limits<double>::infinity();
  // (cost, error): 0 and 2 are dominated by 1; 4 failed; 3 and 5 trade cost for error
  const std::vector<double> cost{2.0, 1.0, 3.0, 4.0, 0.5, 8.0};
  const std::vector<double> error{0.5, 0.4, 0.45, 0.1, inf, 0.05};
  EXPECT_EQ(pareto_front(cost, error), (std::vector<std::size_t>{1, 3, 5}));
  EXPECT_TRUE(pareto_front({}, {}).empty());
}

TEST(PipelineNames, NetworkShapesParseAndName) {
  const auto shape = NetworkShape::parse("5x48x5");
  EXPECT_EQ(shape.latent_dim, 5);
  EXPECT_EQ(shape.width, 48);
  EXPECT_EQ(shape.depth, 5);
  EXPECT_EQ(shape.name(), "r5_w48_d5");
  for (const char* bad : {"5x48", "5x48x1", "0x48x5", "5x48x5x", "five"})
    EXPECT_THROW(NetworkShape::parse(bad), std::invalid_argument) << bad;
  EXPECT_EQ((RomConfiguration{RomMethod::SampleNode, 0, 3.0}).name(), "node_s0_cfl3");
  EXPECT_EQ(default_search_networks(5).size(), 9u);
}

// The legends name each method as docs/rom.md does: the Galerkin step is not Algorithm 2.
TEST(PipelineCharts, MethodsAreNamedInLegends) {
  EXPECT_EQ(method_title("point"), "Algorithm 1");
  EXPECT_EQ(method_title("node"), "Algorithm 2");
  EXPECT_EQ(method_title("galerkin"), "Galerkin step");
}

// A report with the fields report.md reads, and one reduced configuration that held.
nlohmann::json minimal_report() {
  const nlohmann::json errors = {{"position_error", 0.002},
                                 {"displacement_error", 0.02},
                                 {"velocity_error", 0.05},
                                 {"F_error", 0.001},
                                 {"strain_error", 0.01}};
  const nlohmann::json verdict = {{"front_points_below_fom", 0},
                                  {"front", nlohmann::json::array()},
                                  {"metric", "position_error"},
                                  {"range_seconds_per_simulated_second", {0.1, 0.1}}};
  nlohmann::json held = {{"network", "r3_w16_d5"},
                         {"configuration", "galerkin_s8_cfl3"},
                         {"evaluated_points", 188},
                         {"hyper_reduction", nlohmann::json::object()},
                         {"steps", 70},
                         {"rom_seconds_per_rollout_step", 2e-4},
                         {"rollouts", 9},
                         {"cost_seconds_per_simulated_second", 0.056},
                         {"validation", errors},
                         {"test", errors},
                         {"test_vs_reference", errors}};
  return {{"scene", "poke_cylinder"},
          {"command", "mpmrom pipeline"},
          {"device", "cpu"},
          {"backend", "OpenMP"},
          {"threads", 2},
          {"precision", "double"},
          {"git_commit", "0"},
          {"wall_seconds", 60.0},
          {"runs", {{"train", 18}, {"validation", 4}, {"test", 5}}},
          {"comparison", {{"position_error", verdict}, {"displacement_error", verdict}}},
          {"reference_refinement", 2.0},
          {"fom", nlohmann::json::array()},
          {"rom", {held}},
          {"models", nlohmann::json::object()}};
}

// A failed configuration's cells read "failed", and a line below the table says why, as the pipeline printed it.
TEST(PipelineReport, SaysWhyAConfigurationFailed) {
  nlohmann::json report = minimal_report();
  EXPECT_EQ(pipeline_markdown(report, {}).find("Failed configurations"), std::string::npos);
  nlohmann::json failed = report["rom"][0];
  failed["configuration"] = "point_s8_cfl0";
  for (const char* split : {"validation", "test", "test_vs_reference"})
    for (auto& [key, value] : failed[split].items()) value = nullptr;  // what report.json holds for infinity
  failed["failed_rollouts"] = 8;
  failed["failure"] = "stopped at t = 0.22 s: energy blow-up";
  report["rom"].push_back(failed);
  const std::string md = pipeline_markdown(report, {});
  EXPECT_NE(md.find("| r3_w16_d5 | point_s8_cfl0 | 188 | 70 | 0.2 | 0.056 | failed | failed |"), std::string::npos)
      << md;
  EXPECT_NE(md.find("- r3_w16_d5 point_s8_cfl0: 8 of 9 rollouts stopped; the first stopped at t = 0.22 s: energy "
                    "blow-up\n"),
            std::string::npos)
      << md;
  EXPECT_EQ(md.find("- r3_w16_d5 galerkin_s8_cfl3:"), std::string::npos);
}

TEST(PipelineCharts, ScriptAndImagesAreWritten) {
  const auto dir = std::filesystem::temp_directory_path() / ("mpmrom_chart_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  Chart chart{"title", "cost", "error_%", true, true, {}};
  chart.series.push_back({"a", {1, 10, 100}, {3, 2, 1}, "linespoints", {"x", "y", "z"}});
  chart.series.push_back({"b", {0.0, 5}, {1, 1}, "points", {}});  // the zero cost cannot be drawn on a log axis
  const std::string problem = write_chart(dir.string(), "chart", chart);
  std::ifstream script(dir / "chart.gp");
  const std::string text((std::istreambuf_iterator<char>(script)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("10 2 \"y\""), std::string::npos);
  EXPECT_EQ(text.find("\n0 1 "), std::string::npos);
  if (problem.empty()) {  // gnuplot is installed (scripts/install-deps.sh): both images exist and are not empty
    EXPECT_GT(std::filesystem::file_size(dir / "chart.png"), 1000u);
    EXPECT_GT(std::filesystem::file_size(dir / "chart.svg"), 1000u);
  } else {
    EXPECT_NE(problem.find("gnuplot"), std::string::npos) << problem;
  }
  for (const auto& entry : std::filesystem::directory_iterator(dir))  // no temporary left behind
    EXPECT_EQ(entry.path().string().find(".tmp"), std::string::npos) << entry.path();
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace mpmrom::test
