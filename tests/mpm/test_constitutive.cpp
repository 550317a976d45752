// The rotation-variant 3x3 SVD, the polar rotation and the hyperelastic models on device: SVD invariants (and
// polar_rotation = U V^T) on random, near-singular, rank-deficient, inverted, diagonal and repeated-singular-value
// matrices; Newton's polar rotation against the SVD's where it applies; stress against a finite-difference
// derivative of the energy; zero stress and invariance under rotations; Kirchhoff stress; Lame parameters.
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "backends.hpp"
#include "mpm/constitutive.hpp"
#include "core/math/polar3.hpp"

namespace mpmrom::test {
namespace {

using M = Mat3<real_t>;
using MD = Mat3<double>;
template <class ExecutionSpace>
using Matrices = Kokkos::View<real_t* [3][3], typename ExecutionSpace::memory_space>;

constexpr double kEpsDouble = std::numeric_limits<double>::epsilon();
constexpr double kUnknown = std::numeric_limits<double>::quiet_NaN();

// ---- host helpers ----

MD to_double(const M& a) {
  MD b;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) b(i, j) = a(i, j);
  return b;
}
M to_real(const MD& a) {
  M b;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) b(i, j) = static_cast<real_t>(a(i, j));
  return b;
}

// How far polar_rotation(F) may lie from svd3's U V^T, beyond svd3's own orth_tol. Where Newton's iteration applies
// (det F > 0, Frobenius condition kappa = |F| |F^-1| <= kPolar3MaxCondition; a tenth more for the device's roundings
// near the limit) the two are different computations: svd3 is backward stable to recon_tol |F| and Newton's first
// step inverts X by cofactors to about eps kappa / 2 relative, which moves its polar factor by about
// eps kappa^(3/2) / 4 (later steps correct their own roundings); the polar factor moves by at most
// 2 |dF| / (sigma_1 + sigma_2) (the two smallest singular values). Elsewhere polar_rotation is svd3's U V^T: 0.
double newton_polar_gap(const MD& f, double recon_tol, double sigma_1, double sigma_2) {
  const double det = determinant(f);
  if (!(det > 0)) return 0;
  const double kappa = frobenius_norm(f) * frobenius_norm(cofactor(f)) / det;
  if (!(kappa <= 1.1 * kPolar3MaxCondition)) return 0;
  const double fn = frobenius_norm(f);
  return 2 * (recon_tol * fn + eps * std::pow(kappa, 1.5) / 4 * fn) / (sigma_1 + std::fabs(sigma_2));
}

// Uniformly distributed rotation: the matrix of a normalised Gaussian quaternion.
MD random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> normal;
  double q[4], n = 0;
  for (double& x : q) {
    x = normal(rng);
    n += x * x;
  }
  n = std::sqrt(n);
  const double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
  MD r;
  r(0, 0) = 1 - 2 * (y * y + z * z);
  r(0, 1) = 2 * (x * y - w * z);
  r(0, 2) = 2 * (x * z + w * y);
  r(1, 0) = 2 * (x * y + w * z);
  r(1, 1) = 1 - 2 * (x * x + z * z);
  r(1, 2) = 2 * (y * z - w * x);
  r(2, 0) = 2 * (x * z - w * y);
  r(2, 1) = 2 * (y * z + w * x);
  r(2, 2) = 1 - 2 * (x * x + y * y);
  return r;
}

// Q diag(s) W^T with random rotations Q and W: singular values |s|, det sign s0 s1 s2.
MD with_singular_values(std::mt19937_64& rng, double s0, double s1, double s2) {
  return random_rotation(rng) * MD::diagonal(s0, s1, s2) * transpose(random_rotation(rng));
}

template <class ExecutionSpace>
Matrices<ExecutionSpace> to_device(const char* label, const std::vector<M>& fs) {
  Matrices<ExecutionSpace> view(std::string(label), fs.size());
  auto host = Kokkos::create_mirror_view(view);
  for (std::size_t p = 0; p < fs.size(); ++p)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) host(p, i, j) = fs[p](i, j);
  Kokkos::deep_copy(view, host);
  return view;
}

template <class View>
std::vector<M> to_host(const View& view) {
  auto host = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), view);
  std::vector<M> out(host.extent(0));
  for (std::size_t p = 0; p < out.size(); ++p)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) out[p](i, j) = host(p, i, j);
  return out;
}

template <class View>
KOKKOS_INLINE_FUNCTION M load(const View& view, int p) {
  M a;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a(i, j) = view(p, i, j);
  return a;
}
template <class View>
KOKKOS_INLINE_FUNCTION void store(const View& view, int p, const M& a) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) view(p, i, j) = a(i, j);
}

// ---- SVD ----

// One input of the SVD tests: F (as the device sees it) and, where known from the construction, its rotation-variant
// singular values (kUnknown otherwise).
struct SvdCase {
  M F;
  double sigma[3];
};

SvdCase svd_case(const MD& f, double s0 = kUnknown, double s1 = kUnknown, double s2 = kUnknown) {
  return {to_real(f), {s0, s1, s2}};
}

// Rotation-variant singular values of Q diag(s) W^T: |s| sorted descending, the sign of the product on the last.
SvdCase constructed_case(std::mt19937_64& rng, double s0, double s1, double s2) {
  double a[3] = {std::fabs(s0), std::fabs(s1), std::fabs(s2)};
  std::sort(a, a + 3, [](double x, double y) { return x > y; });
  if (s0 * s1 * s2 < 0) a[2] = -a[2];
  return svd_case(with_singular_values(rng, s0, s1, s2), a[0], a[1], a[2]);
}

struct SvdResult {
  std::vector<M> u, v, r;
  std::vector<Vec3<real_t>> sigma;
};

template <class ExecutionSpace>
SvdResult run_svd(const std::vector<SvdCase>& cases) {
  std::vector<M> fs;
  for (const auto& c : cases) fs.push_back(c.F);
  const auto f = to_device<ExecutionSpace>("F", fs);
  const int n = static_cast<int>(fs.size());
  Matrices<ExecutionSpace> u("U", n), v("V", n), r("R", n);
  Kokkos::View<real_t* [3], typename ExecutionSpace::memory_space> sigma("sigma", n);
  Kokkos::parallel_for(
      "mpmrom::test::svd3", Kokkos::RangePolicy<ExecutionSpace>(0, n), KOKKOS_LAMBDA(const int p) {
        const M a = load(f, p);
        M uu, vv;
        Vec3<real_t> s;
        svd3(a, uu, s, vv);
        store(u, p, uu);
        store(v, p, vv);
        store(r, p, polar_rotation(a));
        for (int k = 0; k < 3; ++k) sigma(p, k) = s[k];
      });
  SvdResult out{to_host(u), to_host(v), to_host(r), {}};
  auto s = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), sigma);
  for (int p = 0; p < n; ++p) out.sigma.push_back({{s(p, 0), s(p, 1), s(p, 2)}});
  return out;
}

// Checks every SVD invariant on the device's results, with the residuals computed in double on the host.
template <class ExecutionSpace>
void check_svd(const char* what, const std::vector<SvdCase>& cases) {
  const auto res = run_svd<ExecutionSpace>(cases);
  // Backward error: at most ~15 plane rotations (5 sweeps of 3; measured <= 7 eps |F| over 10^5 matrices), each
  // backward stable to ~2 eps of the two columns it mixes, plus scaling and Gram-Schmidt: 32 eps |F|.
  const double recon_tol = 32 * eps;
  // U: two normalisations and a cross product; V: a product of <= 15 rotations, each orthogonal to ~2 eps.
  const double orth_tol = 32 * eps;
  // R^T F = V diag(sigma) V^T up to the backward error, with |R| = sqrt(3): symmetric to 2 recon_tol |F|.
  const double sym_tol = 64 * eps;
  for (std::size_t p = 0; p < cases.size(); ++p) {
    const MD f = to_double(cases[p].F), u = to_double(res.u[p]), v = to_double(res.v[p]), r = to_double(res.r[p]);
    const double s0 = res.sigma[p][0], s1 = res.sigma[p][1], s2 = res.sigma[p][2];
    const double fn = frobenius_norm(f);
    EXPECT_LE(frobenius_norm(u * MD::diagonal(s0, s1, s2) * transpose(v) - f), recon_tol * fn)
        << what << " " << p << ": U diag(sigma) V^T != F";
    EXPECT_LE(frobenius_norm(transpose(u) * u - MD::identity()), orth_tol) << what << " " << p << ": U not orthogonal";
    EXPECT_LE(frobenius_norm(transpose(v) * v - MD::identity()), orth_tol) << what << " " << p << ": V not orthogonal";
    EXPECT_NEAR(determinant(u), 1.0, orth_tol) << what << " " << p << ": det U != +1";
    EXPECT_NEAR(determinant(v), 1.0, orth_tol) << what << " " << p << ": det V != +1";
    // Ordering is exact: the columns are sorted by the same norms that become sigma.
    EXPECT_GE(s0, s1) << what << " " << p;
    EXPECT_GE(s1, std::fabs(s2)) << what << " " << p;
    EXPECT_GE(s1, 0.0) << what << " " << p;
    // det F = s0 s1 s2 (det U = det V = 1): s2 carries the sign. sigma2 is accurate to recon_tol |F| (Weyl), so the
    // product is accurate to that times s0 s1; where |det F| exceeds that, the sign must match exactly.
    const double det_f = determinant(f);  // accurate to ~1e-16 |F|^3: the entries are exact in double
    const double det_tol = recon_tol * fn * s0 * s1 + 8 * kEpsDouble * fn * fn * fn;
    EXPECT_LE(std::fabs(s0 * s1 * s2 - det_f), det_tol) << what << " " << p << ": s0 s1 s2 != det F";
    if (std::fabs(det_f) > 2 * det_tol) {
      EXPECT_EQ(s2 < 0, det_f < 0) << what << " " << p << ": sign of sigma2 is not the sign of det F";
    }
    // Known singular values: Weyl's inequality bounds the change from rounding F to real_t (eps |F|) and from the
    // backward error (recon_tol |F|).
    for (int k = 0; k < 3; ++k) {
      if (!std::isnan(cases[p].sigma[k])) {
        EXPECT_NEAR(res.sigma[p][k], cases[p].sigma[k], (recon_tol + eps) * fn)
            << what << " " << p << ": sigma[" << k << "]";
      }
    }
    // polar_rotation is U V^T (Newton's iteration, or svd3's own where it does not apply), a proper rotation with
    // R^T F symmetric; a gap of |dR| makes R^T F asymmetric by up to 2 |dR| |F|.
    const double gap = newton_polar_gap(f, recon_tol, s1, s2);
    EXPECT_LE(frobenius_norm(r - u * transpose(v)), orth_tol + gap) << what << " " << p << ": polar_rotation != U V^T";
    const MD s = transpose(r) * f;
    EXPECT_LE(frobenius_norm(s - transpose(s)), (sym_tol + 2 * gap) * fn)
        << what << " " << p << ": R^T F not symmetric";
  }
}

template <class ExecutionSpace>
void svd_random() {
  std::mt19937_64 rng(101);
  std::uniform_real_distribution<double> entry(-1, 1);
  std::vector<SvdCase> cases;
  for (int p = 0; p < 2000; ++p) {
    MD f;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) f(i, j) = entry(rng);
    cases.push_back(svd_case(f));
  }
  // Constructed, with known singular values spread over two decades, half of them inverted.
  std::uniform_real_distribution<double> log_s(std::log(0.1), std::log(10.0));
  for (int p = 0; p < 1000; ++p) {
    const double sign = p % 2 ? -1 : 1;
    cases.push_back(constructed_case(rng, std::exp(log_s(rng)), std::exp(log_s(rng)), sign * std::exp(log_s(rng))));
  }
  check_svd<ExecutionSpace>("random", cases);
}

template <class ExecutionSpace>
void svd_near_singular() {
  std::mt19937_64 rng(102);
  std::uniform_real_distribution<double> unit(0.5, 2);
  std::vector<SvdCase> cases;
  for (int p = 0; p < 1000; ++p) {
    const double s0 = unit(rng), s1 = s0 * unit(rng) / 2;
    const double s2 = (p % 2 ? -1e-6 : 1e-6) * s0;  // one singular value 1e-6 relative, either sign of det
    cases.push_back(constructed_case(rng, s0, s1, s2));
  }
  for (int p = 0; p < 200; ++p) {  // two tiny singular values
    const double s0 = unit(rng);
    cases.push_back(constructed_case(rng, s0, 1e-6 * s0, (p % 2 ? -1e-7 : 1e-7) * s0));
  }
  check_svd<ExecutionSpace>("near-singular", cases);
}

template <class ExecutionSpace>
void svd_rank_deficient() {
  // Integer entries keep the linear dependence exact in any precision.
  std::mt19937_64 rng(103);
  std::uniform_int_distribution<int> small(-3, 3);
  std::vector<SvdCase> cases;
  for (int p = 0; p < 500; ++p) {
    MD f;
    const int a = small(rng), b = small(rng);
    for (int i = 0; i < 3; ++i) {
      f(i, 0) = small(rng);
      f(i, 1) = small(rng);
      f(i, 2) = a * f(i, 0) + b * f(i, 1);  // rank <= 2
    }
    cases.push_back(svd_case(p % 2 ? transpose(f) : f, kUnknown, kUnknown, 0));
  }
  for (int p = 0; p < 300; ++p) {
    MD f;
    double x[3], y[3];
    for (int i = 0; i < 3; ++i) {
      x[i] = small(rng);
      y[i] = small(rng);
    }
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) f(i, j) = x[i] * y[j];  // rank <= 1
    cases.push_back(svd_case(f, kUnknown, 0, 0));
  }
  cases.push_back(svd_case(MD::zero(), 0, 0, 0));
  cases.push_back(svd_case(MD::diagonal(0, 0, 3), 3, 0, 0));
  cases.push_back(svd_case(MD::diagonal(2, 0, -3), 3, 2, 0));
  check_svd<ExecutionSpace>("rank-deficient", cases);
  // F = 0: the decomposition is the trivial one.
  const auto zero = run_svd<ExecutionSpace>({svd_case(MD::zero())});
  EXPECT_EQ(frobenius_norm(to_double(zero.u[0]) - MD::identity()), 0.0);
  EXPECT_EQ(frobenius_norm(to_double(zero.v[0]) - MD::identity()), 0.0);
}

template <class ExecutionSpace>
void svd_inverted() {
  std::mt19937_64 rng(104);
  std::uniform_real_distribution<double> s(0.1, 2);
  std::vector<SvdCase> cases;
  for (int p = 0; p < 1000; ++p) {
    // One or three negative stretches: det < 0 either way.
    const double sign01 = p % 2 ? -1 : 1;
    cases.push_back(constructed_case(rng, sign01 * s(rng), sign01 * s(rng), -s(rng)));
  }
  cases.push_back(svd_case(-1.0 * MD::identity(), 1, 1, -1));
  cases.push_back(svd_case(MD::diagonal(1, 1, -1), 1, 1, -1));
  cases.push_back(svd_case(MD::diagonal(-1, 1, 1), 1, 1, -1));
  cases.push_back(svd_case(MD::diagonal(-2, -3, -0.5), 3, 2, -0.5));
  check_svd<ExecutionSpace>("inverted", cases);
}

template <class ExecutionSpace>
void svd_diagonal() {
  std::vector<SvdCase> cases = {
      svd_case(MD::identity(), 1, 1, 1),          svd_case(MD::diagonal(3, 2, 1), 3, 2, 1),
      svd_case(MD::diagonal(1, 2, 3), 3, 2, 1),   svd_case(MD::diagonal(0.5, -2, 1), 2, 1, -0.5),
      svd_case(MD::diagonal(-4, -1, 2), 4, 2, 1), svd_case(MD::diagonal(1e-3, 1, 1e3), 1e3, 1, 1e-3),
  };
  check_svd<ExecutionSpace>("diagonal", cases);
  // The identity decomposes exactly, with U = V (any U = V would do; the rotation is then exactly I).
  const auto id = run_svd<ExecutionSpace>({svd_case(MD::identity())});
  EXPECT_EQ(frobenius_norm(to_double(id.r[0]) - MD::identity()), 0.0);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(id.sigma[0][k], real_t(1));
}

template <class ExecutionSpace>
void svd_repeated() {
  std::mt19937_64 rng(105);
  std::vector<SvdCase> cases;
  for (int p = 0; p < 100; ++p) {
    cases.push_back(constructed_case(rng, 1, 1, 0.5));
    cases.push_back(constructed_case(rng, 2, 1, 1));
    cases.push_back(constructed_case(rng, 0.7, 0.7, -0.7));
    cases.push_back(constructed_case(rng, 1, 1, 0));
    cases.push_back(constructed_case(rng, 1, 1 + 1e-8, 1 - 1e-8));  // nearly repeated
    cases.push_back(constructed_case(rng, 1.5, 1.5, 1.5));          // a scaled rotation
  }
  check_svd<ExecutionSpace>("repeated", cases);
  // For a rotation F (all sigma = 1), the polar rotation is F itself.
  std::vector<SvdCase> rotations;
  for (int p = 0; p < 200; ++p) rotations.push_back(svd_case(random_rotation(rng), 1, 1, 1));
  const auto res = run_svd<ExecutionSpace>(rotations);
  for (std::size_t p = 0; p < rotations.size(); ++p) {
    // R = U V^T equals F up to the backward error of F = U V^T (<= 32 eps) plus F's own departure from orthogonality.
    EXPECT_LE(frobenius_norm(to_double(res.r[p]) - to_double(rotations[p].F)), 64 * eps) << "rotation " << p;
  }
}

template <class ExecutionSpace>
void svd_extreme_scales() {
  // 1e30 squared overflows float and 1e-30 squared underflows it: the scaling by the largest entry must prevent both.
  std::mt19937_64 rng(106);
  std::vector<SvdCase> cases;
  for (const double scale : {1e30, 1e-30}) {
    for (int p = 0; p < 200; ++p) {
      cases.push_back(constructed_case(rng, scale, 0.3 * scale, -0.1 * scale));
      cases.push_back(constructed_case(rng, scale, 0.5 * scale, 1e-6 * scale));
    }
  }
  check_svd<ExecutionSpace>("extreme scales", cases);
}

// ---- constitutive models ----

struct Evaluated {
  std::vector<real_t> energy;
  std::vector<M> piola, kirchhoff;
};

template <class ExecutionSpace>
Evaluated evaluate(const ElasticMaterial<real_t>& material, const std::vector<M>& fs) {
  const auto f = to_device<ExecutionSpace>("F", fs);
  const int n = static_cast<int>(fs.size());
  Kokkos::View<real_t*, typename ExecutionSpace::memory_space> energy("energy", n);
  Matrices<ExecutionSpace> piola("P", n), kirchhoff("tau", n);
  const ElasticMaterial<real_t> m = material;
  Kokkos::parallel_for(
      "mpmrom::test::constitutive", Kokkos::RangePolicy<ExecutionSpace>(0, n), KOKKOS_LAMBDA(const int p) {
        const M a = load(f, p);
        energy(p) = energy_density(m, a);
        store(piola, p, first_piola(m, a));
        store(kirchhoff, p, kirchhoff_stress(m, a));
      });
  Evaluated out{{}, to_host(piola), to_host(kirchhoff)};
  auto e = Kokkos::create_mirror_view_and_copy(Kokkos::HostSpace(), energy);
  for (int p = 0; p < n; ++p) out.energy.push_back(e(p));
  return out;
}

ElasticMaterial<double> in_double(const ElasticMaterial<real_t>& m) { return {m.model, m.mu, m.lambda}; }

// Both models with E = 12500 Pa, nu = 0.3 (mu = 62500/13, lambda = 93750/13).
std::vector<ElasticMaterial<real_t>> materials() {
  return {elastic_material(ElasticModel::NeoHookean, real_t(12500), real_t(0.3)),
          elastic_material(ElasticModel::FixedCorotated, real_t(12500), real_t(0.3))};
}

// Sum of the magnitudes of the six products in det F: rounding moves the computed det F by a few eps times this.
double det_terms(const MD& f) {
  double s = 0;
  for (int a = 0; a < 3; ++a) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    s += std::fabs(f(0, a) * f(1, b) * f(2, c)) + std::fabs(f(0, a) * f(1, c) * f(2, b));
  }
  return s;
}

// Magnitudes that rounding errors scale with, for F with s_lo <= min_{i<j} sigma_i + sigma_j (see Sample): a few eps
// times `energy` bounds the rounding of Psi, a few eps times `stress` that of P. Each is the sum of the magnitudes of
// the terms summed, plus the effect of rounding in J (dPsi/dJ or dP/dJ times det_terms) and, for fixed-corotated, in
// the SVD (sigma and R move by ~8 eps |F| and 2 (8 eps |F|) / s_lo under its backward error).
struct Magnitudes {
  double energy, stress;
};
Magnitudes magnitudes(const ElasticMaterial<double>& m, const MD& f, double s_lo) {
  const double fn = frobenius_norm(f), j = determinant(f), dt = det_terms(f), cof = frobenius_norm(cofactor(f));
  const double sqrt3 = std::sqrt(3.0);
  Magnitudes out;
  if (m.model == ElasticModel::NeoHookean) {
    const double log_j = std::fabs(std::log(std::max(j, neo_hookean_min_jacobian<double>())));
    const double coeff = (m.lambda * log_j + m.mu) / j;               // |lambda ln J - mu| / J = |dPsi/dJ|
    const double dcoeff = (m.lambda * (1 + log_j) + m.mu) / (j * j);  // |d coeff / dJ|
    out.energy = m.mu * (fn * fn + 3) / 2 + m.mu * log_j + m.lambda * log_j * log_j / 2 + coeff * dt;
    out.stress = m.mu * fn + coeff * cof + dcoeff * dt * cof;
  } else {
    out.energy = m.mu * (fn + sqrt3) * (2 * fn + sqrt3) + m.lambda * ((j - 1) * (j - 1) / 2 + std::fabs(j - 1) * dt);
    out.stress = 2 * m.mu * (fn + sqrt3) * (1 + fn / s_lo) + m.lambda * (std::fabs(j - 1) + dt) * cof;
  }
  return out;
}

// A deformation gradient for the stress tests and s_lo <= min_{i<j} sigma_i + sigma_j, the width of the region where
// fixed-corotated is smooth (R = U V^T is unique and smooth where every such sum is positive).
struct Sample {
  M F;
  double s_lo;
};

// Near identity: F = I + A with |A_ij| <= 0.1, so |A|_2 <= 0.3, sigma_i in [0.7, 1.3] (Weyl) and J in [0.34, 2.2].
std::vector<Sample> near_identity_samples(unsigned seed, int n) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> entry(-0.1, 0.1);
  std::vector<Sample> out;
  for (int p = 0; p < n; ++p) {
    MD f = MD::identity();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) f(i, j) += entry(rng);
    out.push_back({to_real(f), 1.4});
  }
  return out;
}

// Moderately large: Q diag(s) W^T with s log-uniform in [0.5, 2] and |J| in [0.5, 2]. inverted: the smallest stretch
// negated (det < 0) and kept 0.25 away from the second (sigma1 + sigma2 >= 0.25, where fixed-corotated is smooth).
std::vector<Sample> large_samples(unsigned seed, int n, bool inverted) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> log_s(std::log(0.5), std::log(2.0));
  std::vector<Sample> out;
  while (static_cast<int>(out.size()) < n) {
    double s[3] = {std::exp(log_s(rng)), std::exp(log_s(rng)), std::exp(log_s(rng))};
    std::sort(s, s + 3, [](double x, double y) { return x > y; });
    const double j = s[0] * s[1] * s[2];
    if (j < 0.5 || j > 2) continue;
    if (inverted) {
      if (s[1] - s[2] < 0.25) continue;
      s[2] = -s[2];
    }
    out.push_back({to_real(with_singular_values(rng, s[0], s[1], s[2])), s[1] + s[2]});
  }
  return out;
}

// P (real_t, on the device) against the central difference of Psi (double, on the host) at the same F, entry by entry.
//
// Tolerance, per entry (i, j), with D_h = (Psi(F + h E_ij) - Psi(F - h E_ij)) / 2h:
//  - truncation: |D_h - dPsi/dF_ij| <= h^2/6 max|Psi'''| along E_ij. J is affine in one entry (J(t) = J + t cof_ij),
//    so tr(F^T F) and lambda/2 (J - 1)^2 contribute nothing and Psi''' comes from ln J or from R alone:
//    neo-Hookean: Psi''' = x^3 (lambda (2 ln J - 3) - 2 mu) with x = (F^-T)_ij, exactly;
//    fixed-corotated: Psi''' = -2 mu (tr S)''', tr S = sum sigma_i, smooth where every sigma_i + sigma_j > 0; along an
//    entry direction |(tr S)'''| <= 1.155 / s^2, s = min_{i<j} sigma_i + sigma_j (measured sup 2/sqrt(3) over 6000
//    samples), so |Psi'''| <= 2.31 mu / s^2: we take 3 mu / s_lo^2.
//  - rounding: each Psi(F +- h E) in double is within 8 eps_d `energy` (see magnitudes()), and the difference is
//    divided by 2h: 8 eps_d energy / h.
//  - evaluation of P in real_t on the device: 8 eps `stress` (P sums a few terms, each a few roundings deep).
// The first two are doubled for margin. F's entries are O(1), so h = cbrt(eps_d) balances truncation (~h^2) against
// rounding (~eps_d / h); in double the bound is ~1e-9 of the stress scale, in float the evaluation term dominates.
template <class ExecutionSpace>
void check_stress_is_energy_derivative(const char* what, const ElasticMaterial<real_t>& material,
                                       const std::vector<Sample>& samples) {
  std::vector<M> fs;
  for (const auto& s : samples) fs.push_back(s.F);
  const auto dev = evaluate<ExecutionSpace>(material, fs);
  const auto m = in_double(material);
  const double h = std::cbrt(kEpsDouble);
  for (std::size_t p = 0; p < samples.size(); ++p) {
    const MD f = to_double(samples[p].F);
    const auto mag = magnitudes(m, f, samples[p].s_lo);
    const MD inv_t = transpose(inverse(f));
    const double log_j = std::log(std::fabs(determinant(f)));
    // The energy in real_t against the same formula in double: both within 8 eps `energy`.
    EXPECT_LE(std::fabs(dev.energy[p] - energy_density(m, f)), 16 * eps * mag.energy) << what << " " << p << ": Psi";
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        MD fp = f, fm = f;
        fp(i, j) += h;
        fm(i, j) -= h;
        const double fd = (energy_density(m, fp) - energy_density(m, fm)) / (fp(i, j) - fm(i, j));
        const double x = std::fabs(inv_t(i, j));
        const double third = m.model == ElasticModel::NeoHookean
                                 ? x * x * x * (m.lambda * std::fabs(2 * log_j - 3) + 2 * m.mu)
                                 : 3 * m.mu / (samples[p].s_lo * samples[p].s_lo);
        const double tol = 2 * (h * h / 6 * third + 8 * kEpsDouble * mag.energy / h) + 8 * eps * mag.stress;
        EXPECT_NEAR(dev.piola[p](i, j), fd, tol) << what << " " << p << ": P(" << i << ", " << j << ")";
      }
    }
  }
}

template <class ExecutionSpace>
void stress_matches_energy_derivative() {
  const auto ms = materials();
  check_stress_is_energy_derivative<ExecutionSpace>("neo-Hookean near I", ms[0], near_identity_samples(201, 300));
  check_stress_is_energy_derivative<ExecutionSpace>("neo-Hookean large", ms[0], large_samples(202, 300, false));
  check_stress_is_energy_derivative<ExecutionSpace>("corotated near I", ms[1], near_identity_samples(203, 300));
  check_stress_is_energy_derivative<ExecutionSpace>("corotated large", ms[1], large_samples(204, 300, false));
  check_stress_is_energy_derivative<ExecutionSpace>("corotated inverted", ms[1], large_samples(205, 300, true));
}

template <class ExecutionSpace>
void zero_stress_at_rotations() {
  std::mt19937_64 rng(301);
  std::vector<M> rotations = {M::identity()};
  for (int p = 0; p < 500; ++p) rotations.push_back(to_real(random_rotation(rng)));
  for (const auto& material : materials()) {
    const auto dev = evaluate<ExecutionSpace>(material, rotations);
    // At F = I every operation is exact (J = 1, ln 1 = 0, Newton's step at I is I: zeta = 1): exactly zero.
    EXPECT_EQ(dev.energy[0], real_t(0));
    EXPECT_EQ(frobenius_norm(to_double(dev.piola[0])), 0.0);
    EXPECT_EQ(frobenius_norm(to_double(dev.kirchhoff[0])), 0.0);
    const auto m = in_double(material);
    for (std::size_t p = 1; p < rotations.size(); ++p) {
      // A rounded rotation is within ~eps of SO(3): energy and stress are rounding-level, relative to their terms.
      const auto mag = magnitudes(m, to_double(rotations[p]), 2.0);
      EXPECT_LE(std::fabs(dev.energy[p]), 32 * eps * mag.energy) << "rotation " << p;
      EXPECT_LE(frobenius_norm(to_double(dev.piola[p])), 16 * eps * mag.stress) << "rotation " << p;
      EXPECT_LE(frobenius_norm(to_double(dev.kirchhoff[p])), 16 * eps * mag.stress * std::sqrt(3.0))
          << "rotation " << p;
    }
  }
}

// Psi(R F) = Psi(F) and P(R F) = R P(F) for random rotations R and F near identity and large.
template <class ExecutionSpace>
void rotation_invariance() {
  std::mt19937_64 rng(302);
  auto samples = near_identity_samples(303, 300);
  const auto large = large_samples(304, 300, false);
  samples.insert(samples.end(), large.begin(), large.end());
  std::vector<M> fs, rfs;
  std::vector<MD> rs;
  for (const auto& s : samples) {
    const MD r = to_double(to_real(random_rotation(rng)));
    rs.push_back(r);
    fs.push_back(s.F);
    rfs.push_back(to_real(r * to_double(s.F)));
  }
  for (const auto& material : materials()) {
    const auto dev = evaluate<ExecutionSpace>(material, fs);
    const auto rot = evaluate<ExecutionSpace>(material, rfs);
    const auto m = in_double(material);
    for (std::size_t p = 0; p < samples.size(); ++p) {
      // Two evaluations, each within the rounding bounds of check_stress_is_energy_derivative, of inputs that differ
      // by the rounding of R F (eps |F|, which the stress magnitude covers through its dJ term).
      const auto mag = magnitudes(m, to_double(fs[p]), samples[p].s_lo);
      EXPECT_NEAR(rot.energy[p], dev.energy[p], 64 * eps * mag.energy) << "Psi(R F), sample " << p;
      EXPECT_LE(frobenius_norm(to_double(rot.piola[p]) - rs[p] * to_double(dev.piola[p])), 32 * eps * mag.stress)
          << "P(R F) != R P(F), sample " << p;
    }
  }
}

// tau = P F^T and is symmetric, for F near identity, large and (fixed-corotated) inverted.
template <class ExecutionSpace>
void kirchhoff_is_p_f_transposed() {
  for (const auto& material : materials()) {
    auto samples = near_identity_samples(401, 300);
    const auto large = large_samples(402, 300, false);
    samples.insert(samples.end(), large.begin(), large.end());
    if (material.model == ElasticModel::FixedCorotated) {
      const auto inverted = large_samples(403, 300, true);
      samples.insert(samples.end(), inverted.begin(), inverted.end());
    }
    std::vector<M> fs;
    for (const auto& s : samples) fs.push_back(s.F);
    const auto dev = evaluate<ExecutionSpace>(material, fs);
    const auto m = in_double(material);
    for (std::size_t p = 0; p < samples.size(); ++p) {
      const MD f = to_double(fs[p]), tau = to_double(dev.kirchhoff[p]);
      const auto mag = magnitudes(m, f, samples[p].s_lo);
      // Both sides carry the evaluation rounding of P (16 eps stress), multiplied by |F|.
      EXPECT_LE(frobenius_norm(tau - multiply_transposed(to_double(dev.piola[p]), f)),
                32 * eps * mag.stress * frobenius_norm(f))
          << "tau != P F^T, sample " << p;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < i; ++j) EXPECT_EQ(tau(i, j), tau(j, i)) << "tau not symmetric, sample " << p;
    }
  }
}

// Singular and inverted F: fixed-corotated against hand values; neo-Hookean finite, clamped, and restoring.
template <class ExecutionSpace>
void singular_and_inverted() {
  const auto ms = materials();
  const double mu = ms[1].mu, lambda = ms[1].lambda;
  // Fixed-corotated at diagonal F: R = I wherever sigma1 + sigma2 > 0, so P = 2 mu (F - I) + lambda (J - 1) cof F.
  // F = diag(2, 1, -0.5): J = -1, cof = diag(-0.5, -1, 2); F = diag(1, 1, 0): J = 0, cof = diag(0, 0, 1);
  // F = 0: sigma = 0, the SVD is U = V = I, so R = I and P = -2 mu I.
  const std::vector<M> fs = {M::diagonal(2, 1, -0.5), M::diagonal(1, 1, 0), M::zero()};
  const std::vector<MD> p_expected = {MD::diagonal(2 * mu + lambda, 2 * lambda, -3 * mu - 4 * lambda),
                                      MD::diagonal(0, 0, -2 * mu - lambda), -2 * mu * MD::identity()};
  const std::vector<double> psi_expected = {mu * (1 + 0 + 2.25) + lambda / 2 * 4, mu + lambda / 2, 3 * mu + lambda / 2};
  const auto fcr = evaluate<ExecutionSpace>(ms[1], fs);
  for (std::size_t p = 0; p < fs.size(); ++p) {
    // A handful of roundings on entries of size <= 3 mu + 4 lambda.
    const double scale = 3 * mu + 4 * lambda;
    EXPECT_LE(frobenius_norm(to_double(fcr.piola[p]) - p_expected[p]), 16 * eps * scale) << "corotated P, case " << p;
    EXPECT_NEAR(fcr.energy[p], psi_expected[p], 16 * eps * scale) << "corotated Psi, case " << p;
  }

  // Neo-Hookean below the clamp (J = 0, J < 0, 0 < J < J_min): finite, equal to the value at J_min for the energy
  // (which depends on F only through |F| and J), and restoring: P : cof F < 0, i.e. Psi decreases as J grows.
  const real_t j_min = neo_hookean_min_jacobian<real_t>();
  const std::vector<M> nh_fs = {M::diagonal(1, 1, 0), M::diagonal(1, 1, -0.5), M::diagonal(2, 1, -3),
                                M::diagonal(1, 1, real_t(1e-3) * j_min), M::diagonal(1, 1, j_min)};
  const auto nh = evaluate<ExecutionSpace>(ms[0], nh_fs);
  for (std::size_t p = 0; p < nh_fs.size(); ++p) {
    EXPECT_TRUE(std::isfinite(nh.energy[p])) << "neo-Hookean Psi, case " << p;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        EXPECT_TRUE(std::isfinite(nh.piola[p](i, j))) << "neo-Hookean P, case " << p;
        EXPECT_TRUE(std::isfinite(nh.kirchhoff[p](i, j))) << "neo-Hookean tau, case " << p;
      }
    EXPECT_LT(ddot(to_double(nh.piola[p]), cofactor(to_double(nh_fs[p]))), 0.0) << "not restoring, case " << p;
  }
  // diag(1, 1, 1e-3 J_min) is clamped to the ln J of diag(1, 1, J_min): the energies differ only through
  // mu/2 |F|^2, by mu/2 (1 - 1e-6) J_min^2; each energy is a sum of terms of size |Psi|, rounded to ~4 eps |Psi|.
  const double d_psi = 0.5 * ms[0].mu * (1 - 1e-6) * (double(j_min) * j_min);
  EXPECT_NEAR(double(nh.energy[4]) - nh.energy[3], d_psi, 8 * eps * std::fabs(nh.energy[4]));
}

template <class ExecutionSpace>
class Svd3Test : public ::testing::Test {};
TYPED_TEST_SUITE(Svd3Test, EnabledBackends, BackendName);

TYPED_TEST(Svd3Test, RandomMatrices) { svd_random<TypeParam>(); }
TYPED_TEST(Svd3Test, NearSingular) { svd_near_singular<TypeParam>(); }
TYPED_TEST(Svd3Test, RankDeficient) { svd_rank_deficient<TypeParam>(); }
TYPED_TEST(Svd3Test, Inverted) { svd_inverted<TypeParam>(); }
TYPED_TEST(Svd3Test, DiagonalAndIdentity) { svd_diagonal<TypeParam>(); }
TYPED_TEST(Svd3Test, RepeatedSingularValues) { svd_repeated<TypeParam>(); }
TYPED_TEST(Svd3Test, ExtremeScales) { svd_extreme_scales<TypeParam>(); }

template <class ExecutionSpace>
class ConstitutiveTest : public ::testing::Test {};
TYPED_TEST_SUITE(ConstitutiveTest, EnabledBackends, BackendName);

TYPED_TEST(ConstitutiveTest, StressMatchesEnergyDerivative) { stress_matches_energy_derivative<TypeParam>(); }
TYPED_TEST(ConstitutiveTest, ZeroStressAtRotations) { zero_stress_at_rotations<TypeParam>(); }
TYPED_TEST(ConstitutiveTest, RotationInvariance) { rotation_invariance<TypeParam>(); }
TYPED_TEST(ConstitutiveTest, KirchhoffIsPFTransposed) { kirchhoff_is_p_f_transposed<TypeParam>(); }
TYPED_TEST(ConstitutiveTest, SingularAndInverted) { singular_and_inverted<TypeParam>(); }

// polar_rotation_newton where it applies (det F > 0, Frobenius condition <= 30): F = Q S with random rotations and
// principal stretches in [0.5, 2] (condition <= 6.1), and F near rotations as MPM's are, against svd3's U V^T within
// newton_polar_gap (svd3's backward error 32 eps |F| and Newton's first inverse, through the polar factor's
// sensitivity); measured far inside it: <= 7.6 eps (double and float, 2e5 such matrices). Where it does not apply it
// says so, and polar_rotation takes svd3's (Svd3Test, check_svd).
TEST(ConstitutiveHost, PolarRotationByNewtonMatchesSvd) {
  std::mt19937_64 rng(31);
  std::uniform_real_distribution<double> stretch(0.5, 2), small(-0.01, 0.01);
  double worst = 0;  // recorded, not asserted: the bound above is per case
  for (int p = 0; p < 2000; ++p) {
    const MD q = random_rotation(rng), axes = random_rotation(rng);
    MD s;
    if (p % 2) {
      s = axes * MD::diagonal(stretch(rng), stretch(rng), stretch(rng)) * transpose(axes);
    } else {
      for (int i = 0; i < 3; ++i)
        for (int j = i; j < 3; ++j) s(i, j) = s(j, i) = (i == j) + small(rng);
    }
    const M f = to_real(q * s);
    M r, u, v;
    Vec3<real_t> sigma;
    ASSERT_TRUE(polar_rotation_newton(f, r)) << p;
    svd3(f, u, sigma, v);
    const double gap = frobenius_norm(to_double(r) - to_double(u) * transpose(to_double(v)));
    EXPECT_LE(gap, 32 * eps + newton_polar_gap(to_double(f), 32 * eps, sigma[1], sigma[2])) << p;
    worst = std::max(worst, gap);
  }
  RecordProperty("worst_gap_in_eps", std::to_string(worst / eps));
  M r;
  EXPECT_FALSE(polar_rotation_newton(M::diagonal(1, 1, -1), r)) << "inverted: svd3's rotation-variant R";
  EXPECT_FALSE(polar_rotation_newton(M::zero(), r));
  M rank_one;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) rank_one(i, j) = real_t((i + 1) * (j + 2)) / real_t(3);  // det at rounding level
  EXPECT_FALSE(polar_rotation_newton(rank_one, r));
  EXPECT_FALSE(polar_rotation_newton(M::diagonal(1, real_t(0.02), real_t(0.02)), r)) << "condition 71 > 30";
  EXPECT_TRUE(polar_rotation_newton(M::diagonal(1, real_t(0.1), real_t(0.1)), r)) << "condition 14 <= 30";
  M nan = M::identity();
  nan(1, 2) = std::numeric_limits<real_t>::quiet_NaN();
  EXPECT_FALSE(polar_rotation_newton(nan, r));
}

TEST(ConstitutiveHost, LameParameters) {
  // E = 12500, nu = 0.3: mu = E / 2.6 = 62500/13 = 4807.692307..., lambda = 0.3 E / (1.3 * 0.4) = 93750/13 =
  // 7211.538...
  const auto m = elastic_material(ElasticModel::NeoHookean, real_t(12500), real_t(0.3));
  EXPECT_EQ(m.model, ElasticModel::NeoHookean);
  // A few roundings, plus nu = 0.3 itself rounded to real_t (relative eps, amplified ~2x by 1 / (1 - 2 nu)).
  EXPECT_NEAR(m.mu, 62500.0 / 13, 8 * eps * 4807.7);
  EXPECT_NEAR(m.lambda, 93750.0 / 13, 8 * eps * 7211.6);
  // P-wave speed at density 1000: sqrt((lambda + 2 mu) / rho) = sqrt(218750 / 13000) = 4.10206327...
  EXPECT_NEAR(stable_time_step_wave_speed(m, real_t(1000)), 4.1020632707118345, 8 * eps * 4.1);
  const auto c = elastic_material(ElasticModel::FixedCorotated, real_t(1), real_t(0));
  EXPECT_EQ(c.model, ElasticModel::FixedCorotated);
  EXPECT_EQ(c.mu, real_t(0.5));
  EXPECT_EQ(c.lambda, real_t(0));
}

}  // namespace
}  // namespace mpmrom::test
