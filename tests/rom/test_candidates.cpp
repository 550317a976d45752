// The offline fits' candidate points on a body larger than their number (rom/detail/snapshots.hpp): spread in space.
#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "mpmrom/model.hpp"
#include "rom/detail/snapshots.hpp"

namespace mpmrom::test {
namespace {

// A 10 x 10 x 80 column of points stored height fastest, as the scenes store a cylinder, with 160 candidates. A
// stride of 50 through that order would keep the heights 0, 10, ..., 70 alone (on the 10^5 cylinder it missed the
// loaded top); here every tenth of the height holds candidates, in increasing order, at most as many as asked for
// and at least an eighth of them (halving the cell multiplies the occupied cells by at most 8, bar lattice
// alignment), and the points on the column's sides as well as inside.
TEST(RomCandidates, SpreadInSpaceOverALatticeColumn) {
  Model model;
  for (int i = 0; i < 10; ++i)
    for (int j = 0; j < 10; ++j)
      for (int k = 0; k < 80; ++k) {
        model.X.insert(model.X.end(), {0.005 * i, 0.005 * j, 0.005 * k});
        model.mass.push_back(1.0);
        model.volume.push_back(1.0);
      }
  const std::vector<int> candidates = impl::all_candidates(model, 160).points;
  EXPECT_LE(candidates.size(), 160u);
  EXPECT_GE(candidates.size(), 20u);
  EXPECT_TRUE(std::is_sorted(candidates.begin(), candidates.end()));
  EXPECT_EQ(std::adjacent_find(candidates.begin(), candidates.end()), candidates.end());
  std::vector<int> per_tenth(10, 0);
  for (const int p : candidates) ++per_tenth[std::size_t((p % 80) / 8)];
  for (int tenth = 0; tenth < 10; ++tenth) EXPECT_GT(per_tenth[std::size_t(tenth)], 0) << "tenth " << tenth;
  // every layer, the surface too: 36 % of the points lie on the column's sides (the point nearest each cell's
  // centre never took them); a draw uniform within the cells takes at least half that share
  const auto on_side = [](int p) {
    const int i = p / 800, j = (p / 80) % 10;
    return i == 0 || i == 9 || j == 0 || j == 9;
  };
  const auto sides = std::count_if(candidates.begin(), candidates.end(), on_side);
  EXPECT_GE(double(sides), 0.18 * double(candidates.size()));
  // no more points than candidates: every point, in order
  const std::vector<int> every = impl::all_candidates(model, 8000).points;
  ASSERT_EQ(every.size(), 8000u);
  for (int p = 0; p < 8000; ++p) EXPECT_EQ(every[std::size_t(p)], p);
}

// The candidates stand for their cells' mass, so that their mass-weighted sums are a quadrature of the body's: on a
// column whose top half is eight times as finely sampled (points of an eighth of the mass), the candidates' masses
// sum to the body's to rounding, and the centre of mass they give is within 2 mm of the body's. Each candidate is a
// draw over its cell's points, off the cell's centre of mass by zero on average and h / sqrt(12) in deviation (h, the
// cell, about 14 mm for the 166 candidates here), so the mean's deviation is about 0.3 mm: 2 mm is 6 of it (it is
// 0.45 mm). A uniform scale of the candidates' own masses put the centre 31 mm low, the top's cells weighing an
// eighth of the bottom's.
TEST(RomCandidates, StandForTheMassOfTheirCells) {
  Model model;
  const auto add = [&model](double spacing, double mass, double z0, int layers) {
    const int across = int(std::lround(0.05 / spacing));
    for (int i = 0; i < across; ++i)
      for (int j = 0; j < across; ++j)
        for (int k = 0; k < layers; ++k) {
          model.X.insert(model.X.end(), {spacing * (i + 0.5), spacing * (j + 0.5), z0 + spacing * (k + 0.5)});
          model.mass.push_back(mass);
          model.volume.push_back(mass);
        }
  };
  add(0.005, 1.0, 0.0, 20);     // z in [0, 0.1]: 10 x 10 x 20 points of mass 1
  add(0.0025, 0.125, 0.1, 40);  // z in [0.1, 0.2]: 20 x 20 x 40 points of mass 1/8
  const impl::Candidates candidates = impl::all_candidates(model, 200);
  ASSERT_EQ(candidates.points.size(), candidates.masses.size());
  ASSERT_LT(candidates.points.size(), model.num_points());
  double body = 0, body_z = 0, sum = 0, sum_z = 0;
  for (std::size_t p = 0; p < model.num_points(); ++p)
    body += model.mass[p], body_z += model.mass[p] * model.X[3 * p + 2];
  for (std::size_t c = 0; c < candidates.points.size(); ++c) {
    sum += candidates.masses[c];
    sum_z += candidates.masses[c] * model.X[3 * std::size_t(candidates.points[c]) + 2];
  }
  EXPECT_NEAR(sum, body, 1e-12 * body);
  EXPECT_NEAR(sum_z / sum, body_z / body, 0.002);
}

}  // namespace
}  // namespace mpmrom::test
