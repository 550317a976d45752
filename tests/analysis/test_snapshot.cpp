// Snapshot files: a synthetic run written and read back exactly, its XDMF side file, nothing left behind by a writer
// that did not commit, and a refusal naming the problem for every kind of bad file. Host only.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

#include "io/hdf5_file.hpp"
#include "mpmrom/model.hpp"
#include "mpmrom/mpmrom_config.hpp"
#include "rom/rom_file.hpp"
#include "mpmrom/snapshot.hpp"
#include "snapshots/snapshot_writer.hpp"
#include "analysis/upgrade.hpp"

namespace mpmrom::test {
namespace {

namespace fs = std::filesystem;

// A fresh directory per test under the system's temporary directory, removed afterwards.
class SnapshotTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string test = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    dir_ = fs::temp_directory_path() / ("mpmrom-test-snapshot-" + std::to_string(::getpid()) + "-" + test);
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  fs::path dir_;
};

// A small run whose arrays hold distinct random values, each exactly representable in real_t.
struct SyntheticRun {
  std::size_t n = 5;
  SnapshotHeader header;
  std::vector<real_t> X, mass, volume;
  std::vector<double> time;
  std::vector<std::vector<real_t>> x, v, F, C;  // one array per frame
};

std::vector<real_t> random_values(std::size_t count, double lo, double hi, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> dist(lo, hi);
  std::vector<real_t> values(count);
  for (auto& value : values) value = static_cast<real_t>(dist(rng));
  return values;
}

SyntheticRun synthetic_run(std::size_t frames = 3) {
  SyntheticRun run;
  // Markup characters in the name check the XDMF escaping; the parameters are deliberately not in alphabetical order.
  run.header.scene_name = "poke <cylinder> & \"friends\"";
  run.header.scene_text = "# a scene\n[material]\nyoungs_modulus = 1.0e6  # Pa\nname = \"jelly ν\"\n\n";
  run.header.parameters = {{"youngs_modulus", 1.0e6}, {"poisson_ratio", 0.3}, {"density", 1000.0}, {"a_last", -2.5}};
  run.header.dx = 0.0125;
  std::mt19937_64 rng(42);
  run.X = random_values(3 * run.n, -1, 1, rng);
  run.mass = random_values(run.n, 0.1, 2, rng);
  run.volume = random_values(run.n, 1e-6, 1e-5, rng);
  for (std::size_t frame = 0; frame < frames; ++frame) {
    run.time.push_back(0.01 * static_cast<double>(frame) + 1e-17);  // not representable in float: time is double
    run.x.push_back(random_values(3 * run.n, -1, 1, rng));
    run.v.push_back(random_values(3 * run.n, -5, 5, rng));
    run.F.push_back(random_values(9 * run.n, 0.5, 1.5, rng));
    run.C.push_back(random_values(9 * run.n, -10, 10, rng));
  }
  return run;
}

void write_run(const std::string& path, const SyntheticRun& run) {
  SnapshotWriter writer(path, run.header, run.n, run.X.data(), run.mass.data(), run.volume.data());
  for (std::size_t frame = 0; frame < run.time.size(); ++frame) {
    writer.append(run.time[frame], run.x[frame].data(), run.v[frame].data(), run.F[frame].data(), run.C[frame].data());
  }
  EXPECT_EQ(writer.num_frames(), run.time.size());
  writer.commit();
}

std::string file_text(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::size_t occurrences(const std::string& text, const std::string& pattern) {
  std::size_t count = 0;
  for (auto at = text.find(pattern); at != std::string::npos; at = text.find(pattern, at + pattern.size())) ++count;
  return count;
}

// read_snapshot must refuse the file with one line that names the file and contains `problem`.
void expect_rejected(const std::string& path, const std::string& problem) {
  try {
    read_snapshot(path);
    ADD_FAILURE() << "read_snapshot accepted " << path << " (expected: " << problem << ")";
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find(problem), std::string::npos) << "message: " << message << "\nexpected: " << problem;
    EXPECT_NE(message.find(path), std::string::npos) << "message does not name the file: " << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << "message is not one line: " << message;
  }
}

TEST_F(SnapshotTest, RoundTripPreservesEveryValueAndTheHeader) {
  const auto run = synthetic_run();
  write_run(path("run.h5"), run);
  const Snapshot read = read_snapshot(path("run.h5"));

  EXPECT_EQ(read.precision, MPMROM_PRECISION_NAME);
  EXPECT_EQ(read.mpmrom_version, MPMROM_VERSION_STRING);
  EXPECT_FALSE(read.git_commit.empty());
  EXPECT_EQ(read.header.scene_name, run.header.scene_name);
  EXPECT_EQ(read.header.scene_text, run.header.scene_text);
  EXPECT_EQ(read.header.parameters, run.header.parameters);  // names, values and order
  EXPECT_EQ(read.header.dx, run.header.dx);
  ASSERT_EQ(read.num_points, run.n);
  ASSERT_EQ(read.num_frames, run.time.size());
  EXPECT_EQ(read.time, run.time);
  const auto expect_exact = [](const std::vector<double>& actual, const std::vector<real_t>& expected,
                               std::size_t offset, const char* what) {
    for (std::size_t i = 0; i < expected.size(); ++i) {
      ASSERT_EQ(actual.at(offset + i), static_cast<double>(expected[i])) << what << " element " << offset + i;
    }
  };
  expect_exact(read.X, run.X, 0, "X");
  expect_exact(read.mass, run.mass, 0, "mass");
  expect_exact(read.volume, run.volume, 0, "volume");
  ASSERT_EQ(read.x.size(), run.time.size() * 3 * run.n);
  ASSERT_EQ(read.F.size(), run.time.size() * 9 * run.n);
  for (std::size_t frame = 0; frame < run.time.size(); ++frame) {
    expect_exact(read.x, run.x[frame], frame * 3 * run.n, "x");
    expect_exact(read.v, run.v[frame], frame * 3 * run.n, "v");
    expect_exact(read.F, run.F[frame], frame * 9 * run.n, "F");
    expect_exact(read.C, run.C[frame], frame * 9 * run.n, "C");
  }
}

// Read at some points (in any order), a run holds exactly those points' values of the whole read, frame by frame;
// a point past the run's count is refused with one line naming the file.
TEST_F(SnapshotTest, ReadingAtSomePointsKeepsExactlyTheirValues) {
  const auto run = synthetic_run();
  write_run(path("run.h5"), run);
  const Snapshot all = read_snapshot(path("run.h5"));
  const std::vector<std::size_t> points{run.n - 1, 0, 2};
  const Snapshot some = read_snapshot(path("run.h5"), SnapshotFields::All, points);
  EXPECT_EQ(some.point_ids, points);
  ASSERT_EQ(some.num_points, points.size());
  EXPECT_EQ(some.num_frames, all.num_frames);
  EXPECT_EQ(some.time, all.time);
  const auto expect_rows = [&](const std::vector<double>& kept, const std::vector<double>& whole, std::size_t width,
                               std::size_t frames, const char* what) {
    ASSERT_EQ(kept.size(), frames * points.size() * width) << what;
    for (std::size_t f = 0; f < frames; ++f)
      for (std::size_t i = 0; i < points.size(); ++i)
        for (std::size_t k = 0; k < width; ++k)
          ASSERT_EQ(kept[(f * points.size() + i) * width + k], whole[(f * all.num_points + points[i]) * width + k])
              << what << " frame " << f << " point " << points[i];
  };
  expect_rows(some.X, all.X, 3, 1, "X");
  expect_rows(some.mass, all.mass, 1, 1, "mass");
  expect_rows(some.volume, all.volume, 1, 1, "volume");
  expect_rows(some.x, all.x, 3, all.num_frames, "x");
  expect_rows(some.v, all.v, 3, all.num_frames, "v");
  expect_rows(some.F, all.F, 9, all.num_frames, "F");
  expect_rows(some.C, all.C, 9, all.num_frames, "C");
  try {
    read_snapshot(path("run.h5"), SnapshotFields::WithoutAffine, {0, run.n});
    ADD_FAILURE() << "a point past the run's count was read";
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("the run has " + std::to_string(run.n)), std::string::npos) << message;
    EXPECT_NE(message.find(path("run.h5")), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

TEST_F(SnapshotTest, RoundTripOfARunWithoutParametersOrFrames) {
  auto run = synthetic_run(0);
  run.header.parameters.clear();
  write_run(path("empty.h5"), run);
  const Snapshot read = read_snapshot(path("empty.h5"));
  EXPECT_TRUE(read.header.parameters.empty());
  EXPECT_EQ(read.num_frames, 0u);
  EXPECT_TRUE(read.x.empty());
}

TEST_F(SnapshotTest, XdmfSideFileHasOneGridPerFrameAndNamesTheH5Relatively) {
  const auto run = synthetic_run();
  write_run(path("run.h5"), run);
  ASSERT_EQ(xdmf_path_for(path("run.h5")), path("run.xmf"));
  ASSERT_TRUE(fs::exists(path("run.xmf")));
  const std::string xmf = file_text(path("run.xmf"));

  EXPECT_EQ(xmf.rfind("<?xml", 0), 0u);
  EXPECT_NE(xmf.find("<Xdmf Version=\"3.0\">"), std::string::npos);
  EXPECT_NE(xmf.find("CollectionType=\"Temporal\""), std::string::npos);
  EXPECT_NE(xmf.find("poke &lt;cylinder&gt; &amp; &quot;friends&quot;"), std::string::npos);
  EXPECT_EQ(occurrences(xmf, "GridType=\"Uniform\""), run.time.size());
  EXPECT_EQ(occurrences(xmf, "<Time Value="), run.time.size());
  EXPECT_EQ(occurrences(xmf, "<Grid "), run.time.size() + 1);
  EXPECT_EQ(occurrences(xmf, "</Grid>"), run.time.size() + 1);
  EXPECT_EQ(occurrences(xmf, "<DataItem"), occurrences(xmf, "</DataItem>"));
  const std::string real = "NumberType=\"Float\" Precision=\"" + std::to_string(sizeof(real_t)) + "\"";
  EXPECT_NE(xmf.find("<Geometry GeometryType=\"XYZ\"><DataItem Dimensions=\"5 3\" " + real +
                     " Format=\"HDF\">run.h5:/xdmf/x/2</DataItem></Geometry>"),
            std::string::npos);
  std::vector<double> times;  // printed with enough digits to read back exactly
  for (auto at = xmf.find("<Time Value=\""); at != std::string::npos; at = xmf.find("<Time Value=\"", at + 1)) {
    times.push_back(std::stod(xmf.substr(at + 13)));
  }
  EXPECT_EQ(times, run.time);
  EXPECT_EQ(occurrences(xmf, ">run.h5:/xdmf/vertices</DataItem>"), run.time.size());
  EXPECT_NE(xmf.find("Dimensions=\"5 3 3\" " + real + " Format=\"HDF\">run.h5:/xdmf/F/1</DataItem>"),
            std::string::npos);
  EXPECT_NE(xmf.find(">run.h5:/reference/mass</DataItem>"), std::string::npos);
  EXPECT_EQ(xmf.find(dir_.string()), std::string::npos) << "the side file names the HDF5 file by an absolute path";
  EXPECT_EQ(xmf.substr(xmf.size() - 8), "</Xdmf>\n");
}

TEST_F(SnapshotTest, XdmfViewsShowEachFrameOfTheGrowingDatasets) {
  const auto run = synthetic_run();
  write_run(path("run.h5"), run);
  const auto file = hdf5::File::open(path("run.h5"));
  const auto xdmf = file.group("xdmf");
  const auto vertices = xdmf.dataset("vertices").read();
  ASSERT_EQ(vertices.size(), run.n);
  for (std::size_t i = 0; i < run.n; ++i) EXPECT_EQ(vertices[i], static_cast<double>(i));
  for (std::size_t frame = 0; frame < run.time.size(); ++frame) {
    const auto x = xdmf.group("x").dataset(std::to_string(frame));
    const auto F = xdmf.group("F").dataset(std::to_string(frame));
    EXPECT_EQ(x.shape(), (std::vector<std::size_t>{run.n, 3}));
    EXPECT_EQ(F.shape(), (std::vector<std::size_t>{run.n, 3, 3}));
    EXPECT_EQ(x.read(), std::vector<double>(run.x[frame].begin(), run.x[frame].end()));
    EXPECT_EQ(xdmf.group("v").dataset(std::to_string(frame)).read(),
              std::vector<double>(run.v[frame].begin(), run.v[frame].end()));
    EXPECT_EQ(F.read(), std::vector<double>(run.F[frame].begin(), run.F[frame].end()));
  }
}

TEST_F(SnapshotTest, WriterDestroyedWithoutCommitLeavesNothingBehind) {
  const auto run = synthetic_run();
  {
    SnapshotWriter writer(path("run.h5"), run.header, run.n, run.X.data(), run.mass.data(), run.volume.data());
    writer.append(run.time[0], run.x[0].data(), run.v[0].data(), run.F[0].data(), run.C[0].data());
    EXPECT_FALSE(fs::exists(path("run.h5")));
  }
  EXPECT_TRUE(fs::is_empty(dir_)) << "a file is left in " << dir_;
}

TEST_F(SnapshotTest, WriterRefusesANonFiniteFrameAndLeavesNothingBehind) {
  auto run = synthetic_run();
  run.x[1][7] = std::numeric_limits<real_t>::quiet_NaN();
  try {
    write_run(path("run.h5"), run);
    ADD_FAILURE() << "the writer accepted a NaN";
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    EXPECT_NE(message.find("frame 1"), std::string::npos) << message;
    EXPECT_NE(message.find("x holds a non-finite value"), std::string::npos) << message;
  }
  EXPECT_TRUE(fs::is_empty(dir_)) << "a file is left in " << dir_;
}

TEST_F(SnapshotTest, WriterRefusesATimeNotAfterThePreviousFrame) {
  auto run = synthetic_run();
  run.time[2] = run.time[1];
  try {
    write_run(path("run.h5"), run);
    ADD_FAILURE() << "the writer accepted a repeated time";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("frame 2 (t = 0.01) is not after the previous frame"), std::string::npos)
        << error.what();
  }
  EXPECT_TRUE(fs::is_empty(dir_)) << "a file is left in " << dir_;
}

TEST_F(SnapshotTest, CommitReplacesAnEarlierSnapshotOfTheSameName) {
  write_run(path("run.h5"), synthetic_run(3));
  write_run(path("run.h5"), synthetic_run(2));
  EXPECT_EQ(read_snapshot(path("run.h5")).num_frames, 2u);
  EXPECT_EQ(occurrences(file_text(path("run.xmf")), "GridType=\"Uniform\""), 2u);
}

TEST_F(SnapshotTest, RejectsAMissingFile) { expect_rejected(path("missing.h5"), "no such snapshot file"); }

TEST_F(SnapshotTest, RejectsAFileThatIsNotHdf5) {
  std::ofstream(path("text.h5")) << "this is not an HDF5 file\n";
  expect_rejected(path("text.h5"), "cannot open as an HDF5 file");
}

TEST_F(SnapshotTest, RejectsATruncatedFile) {
  write_run(path("run.h5"), synthetic_run());
  fs::resize_file(path("run.h5"), fs::file_size(path("run.h5")) / 2);
  expect_rejected(path("run.h5"), "truncated");
}

TEST_F(SnapshotTest, RejectsAnHdf5FileOfAnotherKind) {
  {
    auto file = hdf5::File::create(path("other.h5"));
    const std::vector<double> values{1, 2, 3};
    file.create_dataset("values", hdf5::Element::float64, {3}).write(values.data());
  }
  expect_rejected(path("other.h5"), "not an mpmrom snapshot (no 'format' attribute)");
}

TEST_F(SnapshotTest, RejectsAnotherFormatVersion) {
  write_run(path("run.h5"), synthetic_run());
  hdf5::File::open(path("run.h5"), hdf5::File::Mode::read_write).set_integer_attribute("format_version", 3);
  expect_rejected(path("run.h5"), "snapshot format version 3 is not supported");
}

TEST_F(SnapshotTest, RejectsAnIncompleteFile) {
  write_run(path("run.h5"), synthetic_run());
  hdf5::File::open(path("run.h5"), hdf5::File::Mode::read_write).remove_attribute("complete");
  expect_rejected(path("run.h5"), "incomplete snapshot (the run did not finish)");
}

TEST_F(SnapshotTest, RejectsPositionsOfTheWrongNumberOfPoints) {
  const auto run = synthetic_run();
  write_run(path("run.h5"), run);
  {
    auto file = hdf5::File::open(path("run.h5"), hdf5::File::Mode::read_write);
    file.remove("x");
    auto x = file.create_growing_dataset("x", hdf5::element_of<real_t>(), {run.n + 1, 3});
    const std::vector<real_t> frame(3 * (run.n + 1), real_t(0.5));
    for (std::size_t i = 0; i < run.time.size(); ++i) x.append(frame.data());
  }
  expect_rejected(path("run.h5"), "dataset /x has shape (3, 6, 3), expected (3, 5, 3) for 5 points and 3 frames");
}

TEST_F(SnapshotTest, RejectsANanInPositions) {
  write_run(path("run.h5"), synthetic_run());
  {
    auto x = hdf5::File::open(path("run.h5"), hdf5::File::Mode::read_write).dataset("x");
    auto values = x.read();
    values[3 * 5 + 3 * 4 + 1] = std::numeric_limits<double>::quiet_NaN();  // frame 1, point 4, y
    x.write(values.data());
  }
  expect_rejected(path("run.h5"), "dataset /x holds a non-finite value (nan) at (1, 4, 1)");
}

TEST_F(SnapshotTest, Hdf5ErrorsNameTheFileAndTheObject) {
  write_run(path("run.h5"), synthetic_run());
  const auto file = hdf5::File::open(path("run.h5"));
  try {
    file.group("reference").dataset("nothing");
    ADD_FAILURE() << "opened a dataset that does not exist";
  } catch (const std::runtime_error& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.rfind(path("run.h5") + ": cannot open dataset /reference/nothing: ", 0), 0u) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
  try {
    file.integer_attribute("scene");
    ADD_FAILURE() << "read a string attribute as an integer";
  } catch (const std::runtime_error& error) {
    EXPECT_EQ(std::string(error.what()), path("run.h5") + ": attribute 'scene' of / is not an integer");
  }
}

TEST_F(SnapshotTest, Hdf5StringListAttributesRoundTrip) {
  auto file = hdf5::File::create(path("lists.h5"));
  const std::vector<std::string> names{"b", "", "a ν", "c"};
  file.set_string_list_attribute("names", names);
  file.set_string_list_attribute("none", {});
  EXPECT_EQ(file.string_list_attribute("names"), names);
  EXPECT_TRUE(file.string_list_attribute("none").empty());
}

TEST_F(SnapshotTest, Hdf5StringListDatasetsRoundTripPastTheAttributeLimit) {
  auto file = hdf5::File::create(path("lists.h5"));
  // 20000 strings of up to 12 bytes: about 240 kB, beyond the 64 kB an attribute (an object header message) can hold.
  std::vector<std::string> many;
  for (int i = 0; i < 20000; ++i) many.push_back(i % 3 == 0 ? "" : "rollout " + std::to_string(i));
  file.create_string_list("many", many);
  const std::vector<std::string> short_list{"b", "", "a ν", "c"};  // UTF-8 and an empty entry
  file.create_string_list("short", short_list);
  file.create_string_list("none", {});
  EXPECT_EQ(file.dataset("many").read_strings(), many);
  EXPECT_EQ(file.dataset("short").read_strings(), short_list);
  EXPECT_TRUE(file.dataset("none").read_strings().empty());
}

TEST_F(SnapshotTest, Hdf5StringListReaderRefusesOtherTypes) {
  auto file = hdf5::File::create(path("lists.h5"));
  file.create_dataset("numbers", hdf5::Element::float64, {3}).write(std::vector<double>{1, 2, 3}.data());
  try {
    (void)file.dataset("numbers").read_strings();
    ADD_FAILURE() << "read numbers as strings";
  } catch (const std::runtime_error& error) {
    EXPECT_EQ(std::string(error.what()), path("lists.h5") + ": dataset /numbers is not a list of fixed-length strings");
  }
}

// Files of older mpmrom versions (tests/data/legacy: a snapshot and a model of format 1, ROM files of formats 1 and
// 2, written by the double build) store their string attributes as variable-length strings and their groups as
// symbol tables, both of which libhdf5 1.10 follows unchecked (fuzzing found hangs, crashes and an endless
// allocation there). Every loader refuses them with the remedy in the line; `mpmrom upgrade` converts them.
const fs::path kLegacy = MPMROM_TEST_DATA "/legacy";

template <class Load>
void expect_refused_as_legacy(const fs::path& file, const Load& load) {
  try {
    load(file.string());
    ADD_FAILURE() << file << " was read without trusting it";
  } catch (const std::runtime_error& error) {
    const std::string what = error.what();
    EXPECT_NE(what.find("older mpmrom"), std::string::npos) << what;
    EXPECT_NE(what.find("mpmrom upgrade " + file.string()), std::string::npos) << what;
  }
}

TEST_F(SnapshotTest, LegacyFilesAreRefusedWithTheRemedy) {
  expect_refused_as_legacy(kLegacy / "snapshot_v1.h5", [](const std::string& f) { (void)read_snapshot(f); });
  expect_refused_as_legacy(kLegacy / "model_v1.h5", [](const std::string& f) { (void)load_model(f); });
  expect_refused_as_legacy(kLegacy / "rom_v2.h5", [](const std::string& f) { (void)load_rom(f); });
  expect_refused_as_legacy(kLegacy / "rom_v1.h5", [](const std::string& f) { (void)load_rom(f); });
}

TEST_F(SnapshotTest, UpgradeRewritesLegacyFilesWithTheSameContents) {
  const std::vector<std::string> names{"snapshot_v1.h5", "model_v1.h5", "rom_v2.h5", "rom_v1.h5"};
  for (const auto& name : names) fs::copy(kLegacy / name, dir_);
  // The fixtures were written by a double build: another precision's build refuses to rewrite (and narrow) them.
  if (std::string(MPMROM_PRECISION_NAME) != "double") {
    for (const auto& name : names) {
      try {
        upgrade_file(path(name));
        ADD_FAILURE() << "a " << MPMROM_PRECISION_NAME << " build rewrote the double file " << name;
      } catch (const std::runtime_error& error) {
        EXPECT_NE(std::string(error.what()).find("upgrade it with a double build"), std::string::npos) << error.what();
      }
    }
    return;
  }
  const auto format_version = [](const std::string& f) {
    return hdf5::File::open(f).integer_attribute("format_version");
  };
  Snapshot snapshot_before;
  Model model_before;
  RomFile rom_before;
  {
    const hdf5::TrustLegacyStrings trust;
    snapshot_before = read_snapshot((kLegacy / "snapshot_v1.h5").string());
    model_before = load_model((kLegacy / "model_v1.h5").string());
    rom_before = load_rom((kLegacy / "rom_v2.h5").string());
  }
  EXPECT_NE(upgrade_file(path("snapshot_v1.h5")).find("snapshot format 1 -> 2"), std::string::npos);
  const Snapshot after = read_snapshot(path("snapshot_v1.h5"));
  EXPECT_EQ(format_version(path("snapshot_v1.h5")), snapshot_format_version);
  EXPECT_EQ(after.header.scene_text, snapshot_before.header.scene_text);
  EXPECT_EQ(after.header.parameters, snapshot_before.header.parameters);
  EXPECT_EQ(after.X, snapshot_before.X);
  EXPECT_EQ(after.time, snapshot_before.time);
  EXPECT_EQ(after.x, snapshot_before.x);
  EXPECT_EQ(after.v, snapshot_before.v);
  EXPECT_EQ(after.F, snapshot_before.F);
  EXPECT_EQ(after.C, snapshot_before.C);
  EXPECT_NE(upgrade_file(path("snapshot_v1.h5")).find("current already"), std::string::npos);

  EXPECT_NE(upgrade_file(path("model_v1.h5")).find("model format 1 -> 2"), std::string::npos);
  const Model model_after = load_model(path("model_v1.h5"));
  EXPECT_EQ(format_version(path("model_v1.h5")), model_format_version);
  EXPECT_EQ(model_after.weights, model_before.weights);
  EXPECT_EQ(model_after.codes, model_before.codes);
  EXPECT_EQ(model_after.scene_text, model_before.scene_text);
  EXPECT_EQ(model_after.settings, model_before.settings);
  EXPECT_EQ(model_after.runs, model_before.runs);

  for (const char* name : {"rom_v2.h5", "rom_v1.h5"}) {
    EXPECT_NE(upgrade_file(path(name)).find("ROM file format"), std::string::npos);
    const RomFile rom_after = load_rom(path(name));
    EXPECT_EQ(format_version(path(name)), rom_format_version);
    EXPECT_EQ(rom_after.result.xhat.size(), rom_before.result.xhat.size()) << name;
    EXPECT_EQ(rom_after.settings, rom_before.settings) << name;
    EXPECT_EQ(rom_after.result.parameter_names, rom_before.result.parameter_names) << name;
  }
  EXPECT_EQ(load_rom(path("rom_v2.h5")).result.xhat, rom_before.result.xhat);
}

// Found by fuzzing: a dataset that stores less than its shape needs made libhdf5 1.10 read past its own buffer.
// Such a dataset (here one created and never written) is refused before reading.
TEST_F(SnapshotTest, Hdf5DatasetStoringLessThanItsShapeIsRefused) {
  auto file = hdf5::File::create(path("unwritten.h5"));
  file.create_dataset("x", hdf5::Element::float64, {10, 3});  // 240 bytes: less than the file already holds
  try {
    (void)file.dataset("x").read();
    ADD_FAILURE() << "read an unwritten dataset";
  } catch (const std::runtime_error& error) {
    EXPECT_EQ(std::string(error.what()), path("unwritten.h5") + ": dataset /x is truncated or unwritten");
  }
}

// Found by fuzzing: an index of 4.3e13 in a ROM file was converted to int unchecked (undefined behaviour). Every
// integer a loader takes from a file is checked to be a whole number in range first.
TEST_F(SnapshotTest, RomFileWithAnIndexOutOfRangeIsRefused) {
  fs::copy(MPMROM_TEST_DATA "/../../fuzz/corpus/hdf5/rom.h5", path("rom.h5"));
  for (const double bad_index : {4.3e13, -1.0, 2.5}) {
    {
      auto file = hdf5::File::open(path("rom.h5"), hdf5::File::Mode::read_write);
      auto samples = file.group("samples");
      const std::size_t count = samples.dataset("indices").shape().at(0);
      std::vector<double> indices(count, 0.0);
      indices.back() = bad_index;
      samples.remove("indices");
      samples.create_dataset("indices", hdf5::Element::float64, {count}).write(indices.data());
    }
    try {
      (void)load_rom(path("rom.h5"));
      ADD_FAILURE() << "read a sample index of " << bad_index;
    } catch (const std::runtime_error& error) {
      EXPECT_NE(std::string(error.what()).find("/samples/indices entry"), std::string::npos) << error.what();
    }
  }
}

// A batch of 20000 rollouts: the per-rollout strings (split, messages, warnings) of ROM format version 1 were
// attributes and could not be written past about 10^4 rollouts.
TEST_F(SnapshotTest, RomFileWithManyRolloutsRoundTrips) {
  constexpr std::size_t rollouts = 20000, frames = 2, r = 2;
  RomFile rom;
  RomResult& res = rom.result;
  res.parameter_names = {"rho"};
  res.latent_dim = int(r);
  res.times = {0.0, 0.1};
  res.steps = 4;
  for (std::size_t b = 0; b < rollouts; ++b) {
    res.cases.push_back({{1.0 + double(b)}, b % 2 == 0 ? "test" : "validation"});
    RolloutOutcome outcome;
    outcome.frames_completed = int(frames);
    outcome.message = b % 7 == 0 ? "stopped: rollout " + std::to_string(b) : "";
    outcome.warning = b % 5 == 0 ? "rho is 0.5 widths above the training range" : "";
    res.outcomes.push_back(outcome);
    for (std::size_t k = 0; k < frames * r; ++k) {
      res.xhat.push_back(double(b) + 0.25 * double(k));
      res.xhatdot.push_back(-double(k));
    }
  }
  rom.model_path = "model.h5";
  rom.scene_name = "synthetic";
  save_rom(path("rom.h5"), rom);
  const RomFile read = load_rom(path("rom.h5"));
  ASSERT_EQ(read.result.cases.size(), rollouts);
  EXPECT_EQ(read.result.xhat, res.xhat);
  EXPECT_EQ(read.result.xhatdot, res.xhatdot);
  for (std::size_t b = 0; b < rollouts; ++b) {
    ASSERT_EQ(read.result.cases[b].split, res.cases[b].split) << b;
    ASSERT_EQ(read.result.cases[b].values, res.cases[b].values) << b;
    ASSERT_EQ(read.result.outcomes[b].message, res.outcomes[b].message) << b;
    ASSERT_EQ(read.result.outcomes[b].warning, res.outcomes[b].warning) << b;
  }
}

// Decoded rollouts get an XDMF side file: a temporal collection whose frames hold one point cloud per rollout, each
// reading a view of its own slice of /decoded.
TEST_F(SnapshotTest, RomFileWithDecodedFieldsHasAnXdmfSideFile) {
  constexpr std::size_t rollouts = 2, frames = 3, n = 4;
  RomFile rom;
  RomResult& res = rom.result;
  res.parameter_names = {"push"};
  res.latent_dim = 1;
  res.times = {0.0, 0.5, 1.0};
  for (std::size_t b = 0; b < rollouts; ++b) {
    res.cases.push_back({{double(b)}, ""});
    res.outcomes.push_back({});
    res.xhat.insert(res.xhat.end(), frames, 0.0);
    res.xhatdot.insert(res.xhatdot.end(), frames, 0.0);
  }
  for (std::size_t i = 0; i < 3 * n; ++i) rom.decoded_X.push_back(double(i));
  for (std::size_t i = 0; i < rollouts * frames * n * 3; ++i) {
    rom.decoded_x.push_back(0.5 * double(i));
    rom.decoded_v.push_back(-double(i));
  }
  rom.decoded_F.assign(rollouts * frames * n * 9, 1.0);
  save_rom(path("rom.h5"), rom);
  ASSERT_TRUE(fs::exists(path("rom.xmf")));
  const std::string xmf = file_text(path("rom.xmf"));
  EXPECT_EQ(occurrences(xmf, "CollectionType=\"Spatial\""), frames);
  EXPECT_EQ(occurrences(xmf, "GridType=\"Uniform\""), frames * rollouts);
  EXPECT_NE(xmf.find("rollout 1 (push = 1)"), std::string::npos);
  EXPECT_NE(xmf.find("rom.h5:/xdmf/x/1/2"), std::string::npos);
  // The view of rollout 1, frame 2 holds that slice of /decoded/x.
  const auto file = hdf5::File::open(path("rom.h5"));
  const auto view = file.group("xdmf").group("x").group("1").dataset("2").read();
  ASSERT_EQ(view.size(), n * 3);
  for (std::size_t i = 0; i < n * 3; ++i) EXPECT_EQ(view[i], rom.decoded_x[(1 * frames + 2) * n * 3 + i]);
  EXPECT_NO_THROW(load_rom(path("rom.h5")));
}

}  // namespace
}  // namespace mpmrom::test
