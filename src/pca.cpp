#include "pca.hpp"

#include <Eigen/Dense>

#include <cmath>

namespace mpmrom {

std::vector<double> principal_coordinates(const std::vector<double>& data, std::size_t rows, std::size_t cols, int r) {
  using Matrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
  Eigen::Map<const Matrix> A(data.data(), Eigen::Index(rows), Eigen::Index(cols));
  const Matrix centred = A.rowwise() - A.colwise().mean();
  // The rows x rows Gram matrix: its eigenvectors scaled by sqrt(eigenvalue) are the principal coordinates, and it
  // is small when there are fewer snapshots than point coordinates.
  const Eigen::MatrixXd gram = centred * centred.transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> solver(gram);
  std::vector<double> coordinates(rows * std::size_t(r), 0.0);
  const Eigen::Index n = Eigen::Index(rows);
  const double top = std::max(solver.eigenvalues()(n - 1), 0.0);
  if (top <= 0) return coordinates;
  const double first_spread = std::sqrt(top / double(rows));
  for (int k = 0; k < r && k < n; ++k) {
    const double lambda = solver.eigenvalues()(n - 1 - k);
    if (!(lambda > 1e-12 * top)) break;
    Eigen::VectorXd u = solver.eigenvectors().col(n - 1 - k);
    Eigen::Index largest;
    u.cwiseAbs().maxCoeff(&largest);
    if (u(largest) < 0) u = -u;
    for (Eigen::Index i = 0; i < n; ++i)
      coordinates[std::size_t(i) * r + k] = u(i) * std::sqrt(lambda) / first_spread;
  }
  return coordinates;
}

}  // namespace mpmrom
