// The CPU block kernels' stress across lanes (polar_rotation_lanes, kirchhoff_stress_lanes) against the one-matrix
// routines (polar_rotation, kirchhoff_stress) lane by lane, on generic, near-identity, repeated-singular-value,
// near-singular, rank-deficient, inverted and zero matrices, in blocks where lanes converge after different numbers of
// steps and some take svd3 instead.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "backends.hpp"
#include "mpm/constitutive_lanes.hpp"

namespace mpmrom::test {
namespace {

constexpr int L = 8;
using M = Mat3<real_t>;

// Matrices of every kind polar_rotation and svd3 treat apart, shuffled so that each block of L mixes them.
std::vector<M> mixed_matrices() {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<M> out;
  for (int k = 0; k < 40; ++k) {  // generic, and near the identity as MPM's F are
    M a, near;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        a(i, j) = real_t(u(rng));
        near(i, j) = real_t((i == j) + 0.05 * u(rng));
      }
    out.push_back(a);
    out.push_back(near);
  }
  out.push_back(M::zero());
  out.push_back(M::identity());
  out.push_back(M::diagonal(2, 2, 1));                        // repeated singular values
  out.push_back(M::diagonal(1, 1, -1));                       // inverted
  out.push_back(M::diagonal(3, real_t(1e-7), 0));             // near singular, rank 2
  out.push_back(M::diagonal(1, real_t(0.02), real_t(0.02)));  // condition 71: Newton's first step refuses it
  out.push_back(M::diagonal(1, real_t(0.1), real_t(0.1)));    // condition 14: Newton's
  M not_finite = M::identity(), infinite = M::identity();
  not_finite(0, 1) = std::numeric_limits<real_t>::quiet_NaN();
  infinite(2, 0) = std::numeric_limits<real_t>::infinity();
  out.push_back(not_finite);
  out.push_back(infinite);
  M rank_one = M::zero();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) rank_one(i, j) = real_t((i + 1) * (j + 2));
  out.push_back(rank_one);
  std::shuffle(out.begin(), out.end(), rng);
  while (out.size() % L != 0) out.push_back(M::identity());
  return out;
}

// Lane by lane, polar_rotation_lanes gives polar_rotation: Newton's steps in the same order (lanes that converge
// early are held while others step) or svd3 itself where the iteration does not apply, so they differ only where the
// compiler contracts a multiply-add differently; Newton's iteration corrects earlier roundings, leaving those of its
// last steps (a few eps of O(1) entries) and svd3's (as before: a few roundings a rotation over at most kSvd3MaxSweeps
// sweeps): 64 eps.
TEST(StressLanes, PolarRotationLanesMatchesPolarRotationLaneByLane) {
  const std::vector<M> fs = mixed_matrices();
  double worst = 0;
  for (std::size_t first = 0; first < fs.size(); first += L) {
    real_t F[3][3][L], R[3][3][L];
    for (int l = 0; l < L; ++l)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) F[i][j][l] = fs[first + l](i, j);
    polar_rotation_lanes(F, R);
    for (int l = 0; l < L; ++l) {
      const M r = polar_rotation(fs[first + l]);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          // a non-finite input gives a non-finite rotation on both paths (svd3's non-finite sigma and factors)
          EXPECT_EQ(std::isfinite(R[i][j][l]), std::isfinite(r(i, j))) << first + l;
          if (std::isfinite(r(i, j))) worst = std::max(worst, std::fabs(double(R[i][j][l]) - r(i, j)));
        }
    }
  }
  EXPECT_LE(worst, 64 * eps);
}

// kirchhoff_stress_lanes gives kirchhoff_stress and its energy lane by lane, for both models, to 64 eps of the
// lane's largest entry (or energy), at least mu + lambda: a few roundings, as above (neo-Hookean's clamped J on the
// singular cases gives entries far above mu + lambda).
TEST(StressLanes, KirchhoffStressLanesMatchesKirchhoffStress) {
  const std::vector<M> fs = mixed_matrices();
  for (const ElasticModel model : {ElasticModel::FixedCorotated, ElasticModel::NeoHookean}) {
    const auto material = elastic_material(model, real_t(1e3), real_t(0.3));
    double worst_tau = 0, worst_psi = 0;
    for (std::size_t first = 0; first < fs.size(); first += L) {
      real_t F[3][3][L], tau[3][3][L], psi[L];
      for (int l = 0; l < L; ++l)
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) F[i][j][l] = fs[first + l](i, j);
      kirchhoff_stress_lanes(material, F, tau, &psi);
      for (int l = 0; l < L; ++l) {
        real_t energy = 0;
        const M expected = kirchhoff_stress(material, fs[first + l], &energy);
        double scale = double(material.mu + material.lambda);
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j) scale = std::max(scale, std::fabs(double(expected(i, j))));
        worst_psi =
            std::max(worst_psi, std::fabs(double(psi[l]) - energy) / std::max(scale, std::fabs(double(energy))));
        for (int i = 0; i < 3; ++i)
          for (int j = 0; j < 3; ++j)
            worst_tau = std::max(worst_tau, std::fabs(double(tau[i][j][l]) - expected(i, j)) / scale);
      }
    }
    EXPECT_LE(worst_tau, 64 * eps) << "model " << int(model);
    EXPECT_LE(worst_psi, 64 * eps) << "model " << int(model);
  }
}

}  // namespace
}  // namespace mpmrom::test
