// Material-point sampling: exact lattice counts (the paper's 1368-point cylinder), Poisson-disk spacing, volumes.
#include <cmath>

#include "backends.hpp"
#include "fixtures.hpp"
#include "scene/sampling.hpp"

namespace mpmrom::test {
namespace {

BodySpec poke_cylinder() {
  BodySpec b;
  b.name = "cylinder";
  b.shape = ShapeKind::Cylinder;
  b.center = {0, 0, 0.2};
  b.radius = 0.1;
  b.height = 0.4;
  b.half_extents = {0.1, 0.1, 0.2};
  return b;
}

TEST(Sampling, LatticeCountReproducesThePapersCylinder) {
  const BodySpec b = poke_cylinder();
  const double spacing = lattice_spacing_for_count(b, 1368);
  const auto points = lattice_points(b, spacing);
  EXPECT_EQ(points.size(), 1368u);
  // 76 points per layer and 18 layers (the count is exact only for spacings in [2.1053, 2.1082] cm).
  EXPECT_GT(spacing, 0.02105);
  EXPECT_LT(spacing, 0.02109);
  for (const auto& p : points) EXPECT_TRUE(body_contains(b, p));
}

// A needle far longer than the spacing: its lattice spans more than an int's range of points along its length,
// refused before any conversion (its volume alone, a fraction of a point, would have let it through).
TEST(Sampling, LatticeSpanningMoreThanAnIntIsRefused) {
  BodySpec needle;
  needle.name = "needle";
  needle.shape = ShapeKind::Box;
  needle.half_extents = {8589934592.0, 1e-9, 1e-9};  // 2^33
  try {
    (void)lattice_points(needle, 1.0);
    ADD_FAILURE() << "a lattice of 2^34 points along one axis was accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_EQ(std::string(error.what()),
              "body 'needle': its half-width in lattice spacings must be a whole number in [1, 2147483647], not "
              "8589934593");
  }
  try {
    (void)poisson_disk_points(needle, 1.0, 1);
    ADD_FAILURE() << "a Poisson-disk grid of 3e10 cells along one axis was accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("over 4e8 cells"), std::string::npos) << error.what();
  }
}

TEST(Sampling, LatticeIsSymmetricAboutTheCenter) {
  const BodySpec b = poke_cylinder();
  const auto points = lattice_points(b, 0.02);
  double sum[3] = {0, 0, 0};
  for (const auto& p : points)
    for (int d = 0; d < 3; ++d) sum[d] += p[d] - b.center[d];
  for (int d = 0; d < 3; ++d) EXPECT_NEAR(sum[d] / points.size(), 0.0, 1e-12);
}

TEST(Sampling, PoissonDiskKeepsItsMinimumDistanceAndFillsTheShape) {
  BodySpec b;
  b.shape = ShapeKind::Sphere;
  b.center = {0.5, 0.5, 0.5};
  b.radius = 0.2;
  b.half_extents = {0.2, 0.2, 0.2};
  const double r = 0.03;
  const auto points = poisson_disk_points(b, r, 7);
  for (std::size_t i = 0; i < points.size(); ++i) {
    ASSERT_TRUE(body_contains(b, points[i]));
    for (std::size_t j = i + 1; j < points.size(); ++j) {
      double d2 = 0;
      for (int d = 0; d < 3; ++d) d2 += (points[i][d] - points[j][d]) * (points[i][d] - points[j][d]);
      ASSERT_GE(std::sqrt(d2), r * (1 - 1e-12)) << "points " << i << " and " << j;
    }
  }
  // Maximal Poisson-disk sets in 3D pack at a density of about 0.6-0.7 / r^3 (Bridson's 30 attempts reach it):
  // fewer than 0.4 / r^3 would mean holes.
  EXPECT_GT(points.size(), 0.4 * body_volume(b) / (r * r * r));
  // Same seed, same points.
  EXPECT_EQ(poisson_disk_points(b, r, 7).size(), points.size());
}

TEST(Sampling, VolumesAndMassesAddUpToTheBody) {
  const Scene scene = fixture_scene("two_bodies.toml");
  const ParticleSamples s = sample_scene(scene);
  double volume[2] = {0, 0}, mass[2] = {0, 0};
  for (std::size_t p = 0; p < s.size(); ++p) {
    volume[s.body[p]] += s.volume[p];
    mass[s.body[p]] += s.mass[p];
  }
  for (int k = 0; k < 2; ++k) {
    EXPECT_NEAR(volume[k], body_volume(scene.bodies[k]), 1e-12);
    EXPECT_NEAR(mass[k], 250.0 * body_volume(scene.bodies[k]), 1e-9);
  }
}

}  // namespace
}  // namespace mpmrom::test
