// Principal components on the host, for initialising the auto-decoder's latent codes. Written out (Gram matrix,
// subspace iteration, Jacobi) rather than with Eigen: Eigen's blocked products crashed in the CUDA build's host code.
#pragma once

#include <cstddef>
#include <vector>

namespace mpmrom {

// Coordinates of each of the `rows` samples (data: rows x cols, row-major) along the r leading principal components
// of the centred data, (rows, r) row-major, all divided by the standard deviation along the first component (so
// the leading coordinate has unit spread and the others keep their relative size). Components beyond the data's
// rank come out as zero. Deterministic: the sign of each component is fixed by its largest entry.
std::vector<double> principal_coordinates(const std::vector<double>& data, std::size_t rows, std::size_t cols, int r);

}  // namespace mpmrom
