// The CPU block kernels' stress across lanes (svd3_lanes, kirchhoff_stress_lanes) against the one-matrix routines
// (svd3, kirchhoff_stress) lane by lane, on generic, repeated-singular-value, near-singular, rank-deficient,
// inverted and zero matrices, in blocks where lanes converge after different numbers of sweeps.
#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "backends.hpp"
#include "mpm/constitutive_lanes.hpp"

namespace mpmrom::test {
namespace {

constexpr int L = 8;
using M = Mat3<real_t>;

// Matrices of every kind svd3 treats apart, shuffled so that each block of L mixes them.
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
  out.push_back(M::diagonal(2, 2, 1));             // repeated singular values
  out.push_back(M::diagonal(1, 1, -1));            // inverted
  out.push_back(M::diagonal(3, real_t(1e-7), 0));  // near singular, rank 2
  M rank_one = M::zero();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) rank_one(i, j) = real_t((i + 1) * (j + 2));
  out.push_back(rank_one);
  std::shuffle(out.begin(), out.end(), rng);
  while (out.size() % L != 0) out.push_back(M::identity());
  return out;
}

// Lane by lane, svd3_lanes gives svd3's factors: the same operations in the same order, so they differ only where
// the compiler contracts a multiply-add differently (a few roundings of O(1) entries a rotation, over at most
// kSvd3MaxSweeps sweeps); 64 eps of |F| allows that for sigma and of 1 for U and V. Degenerate cases keep that
// bound as long as both take the same branches, which the same inputs and nearly the same roundings give here.
TEST(StressLanes, Svd3LanesMatchesSvd3LaneByLane) {
  const std::vector<M> fs = mixed_matrices();
  double worst_sigma = 0, worst_rotation = 0;
  for (std::size_t first = 0; first < fs.size(); first += L) {
    real_t F[3][3][L], U[3][3][L], sigma[3][L], V[3][3][L];
    for (int l = 0; l < L; ++l)
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) F[i][j][l] = fs[first + l](i, j);
    svd3_lanes(F, U, sigma, V);
    for (int l = 0; l < L; ++l) {
      M u, v;
      Vec3<real_t> s;
      svd3(fs[first + l], u, s, v);
      const double size = std::max(1e-30, double(frobenius_norm(fs[first + l])));
      for (int i = 0; i < 3; ++i) {
        worst_sigma = std::max(worst_sigma, std::fabs(double(sigma[i][l]) - s[i]) / size);
        for (int j = 0; j < 3; ++j)
          worst_rotation = std::max(
              {worst_rotation, std::fabs(double(U[i][j][l]) - u(i, j)), std::fabs(double(V[i][j][l]) - v(i, j))});
      }
    }
  }
  EXPECT_LE(worst_sigma, 64 * eps);
  EXPECT_LE(worst_rotation, 64 * eps);
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
