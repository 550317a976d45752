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
  const std::vector<int> candidates = impl::all_candidates(model, 160);
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
  const std::vector<int> every = impl::all_candidates(model, 8000);
  ASSERT_EQ(every.size(), 8000u);
  for (int p = 0; p < 8000; ++p) EXPECT_EQ(every[std::size_t(p)], p);
}

}  // namespace
}  // namespace mpmrom::test
