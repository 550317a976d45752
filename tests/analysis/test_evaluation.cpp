// Errors of a full-order run against a reference at another resolution: exact for affine motion, zero against
// itself, and a transfer error that falls as h^2 on smooth motion (the first-order expansion's remainder).
#include <cmath>
#include <stdexcept>

#include "backends.hpp"
#include "analysis/evaluation.hpp"

namespace mpmrom::test {
namespace {

// A snapshot of the motion x = phi(X, t) on a cubic lattice of n^3 points spanning [0, 1)^3 with spacing 1/n,
// F = dphi/dX and C = Fdot F^-1 from the closed forms below.
struct Motion {
  // x = A(t) X + b(t) + eps sin(k X_0) e_2: affine plus a smooth bend along x_2
  double eps = 0, k = 0;
  void at(const double X[3], double t, double x[3], double v[3], double F[9], double C[9]) const {
    const double s = 1 + 0.2 * t, w = 0.1 * t;  // stretch and shear growing in time
    const double bend = eps * t * std::sin(k * X[0]), bend_rate = eps * std::sin(k * X[0]);
    const double slope = eps * t * k * std::cos(k * X[0]), slope_rate = eps * k * std::cos(k * X[0]);
    x[0] = s * X[0] + w * X[1] + 0.3 * t;
    x[1] = s * X[1];
    x[2] = X[2] + bend;
    v[0] = 0.2 * X[0] + 0.1 * X[1] + 0.3;
    v[1] = 0.2 * X[1];
    v[2] = bend_rate;
    const double Fm[9] = {s, w, 0, 0, s, 0, slope, 0, 1};
    const double Fdot[9] = {0.2, 0.1, 0, 0, 0.2, 0, slope_rate, 0, 0};
    // F^-1 of this lower-block form, written out
    const double Finv[9] = {1 / s, -w / (s * s), 0, 0, 1 / s, 0, -slope / s, slope * w / (s * s), 1};
    for (int i = 0; i < 9; ++i) F[i] = Fm[i];
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) {
        C[3 * a + b] = 0;
        for (int c = 0; c < 3; ++c) C[3 * a + b] += Fdot[3 * a + c] * Finv[3 * c + b];
      }
  }
};

Snapshot lattice_run(int n, const Motion& motion, int frames = 3) {
  Snapshot s;
  s.num_points = std::size_t(n) * n * n;
  s.num_frames = std::size_t(frames);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k)
        for (double c : {(i + 0.5) / n, (j + 0.5) / n, (k + 0.5) / n}) s.X.push_back(c);
  for (int f = 0; f < frames; ++f) {
    s.time.push_back(0.5 * f);
    for (std::size_t p = 0; p < s.num_points; ++p) {
      double x[3], v[3], F[9], C[9];
      motion.at(&s.X[3 * p], s.time.back(), x, v, F, C);
      s.x.insert(s.x.end(), x, x + 3);
      s.v.insert(s.v.end(), v, v + 3);
      s.F.insert(s.F.end(), F, F + 9);
      s.C.insert(s.C.end(), C, C + 9);
    }
  }
  return s;
}

TEST(ResolutionErrors, AffineMotionTransfersExactly) {
  const Motion affine;
  const auto m = resolution_errors(lattice_run(12, affine), lattice_run(5, affine)).metrics();
  // round-off only: every quantity is a short sum of O(1) products
  for (double e : {m.position_error, m.displacement_error, m.velocity_error, m.F_error, m.strain_error})
    EXPECT_LT(e, 1e-13);
}

TEST(ResolutionErrors, ARunAgainstItselfHasNoError) {
  const Motion bent{0.05, 6.0};
  const Snapshot run = lattice_run(6, bent);
  const auto m = resolution_errors(run, run).metrics();
  for (double e : {m.position_error, m.displacement_error, m.velocity_error, m.F_error, m.strain_error})
    EXPECT_EQ(e, 0.0);
}

TEST(ResolutionErrors, TransferErrorFallsAsSpacingSquared) {
  // The expansion x_p + F_p dX leaves eps t k^2 sin(k X_0) dX_0^2 / 2: the position error is the RMS of dX_0^2 (times
  // the same smooth factor), and F's error, taken at the nearest point, the RMS of dX_0. Against a 24^3 lattice, a
  // 12^3 lattice's nearest points lie 1/48 away along X_0, a 6^3 lattice's 1/48 or 3/48 (equally often), so
  // h^2 predicts sqrt((1 + 81) / 2) = sqrt(41) for the position ratio and first order sqrt((1 + 9) / 2) = sqrt(5) for
  // F.
  const Motion bent{0.05, 6.0};
  const Snapshot reference = lattice_run(24, bent);
  const auto coarse = resolution_errors(reference, lattice_run(6, bent)).metrics();
  const auto fine = resolution_errors(reference, lattice_run(12, bent)).metrics();
  EXPECT_GT(fine.position_error, 0);
  // 10 %: the smooth factor sin(k X_0) varies over a coarse cell (k h = 1 at 6^3) and enters the weights
  EXPECT_NEAR(coarse.position_error / fine.position_error, std::sqrt(41.0), 0.1 * std::sqrt(41.0));
  EXPECT_NEAR(coarse.F_error / fine.F_error, std::sqrt(5.0), 0.1 * std::sqrt(5.0));
}

TEST(ResolutionErrors, MismatchedOutputTimesAreRefused) {
  const Motion affine;
  EXPECT_THROW(resolution_errors(lattice_run(4, affine, 3), lattice_run(4, affine, 2)), std::runtime_error);
}

}  // namespace
}  // namespace mpmrom::test
