#include "snapshots/metrics.hpp"

#include <cmath>
#include <limits>
#include <sstream>

namespace mpmrom {
namespace {

double ratio(double misfit, double norm) {
  if (norm > 0) return std::sqrt(misfit / norm);
  return misfit > 0 ? std::numeric_limits<double>::infinity() : 0.0;
}

}  // namespace

nlohmann::json to_json(const ErrorMetrics& m) {
  return {{"position_error", m.position_error},
          {"displacement_error", m.displacement_error},
          {"velocity_error", m.velocity_error},
          {"F_error", m.F_error},
          {"strain_error", m.strain_error}};
}

std::string to_percent_string(const ErrorMetrics& m) {
  std::ostringstream out;
  out.precision(3);
  out << "position " << 100 * m.position_error << " %, displacement " << 100 * m.displacement_error << " %, velocity "
      << 100 * m.velocity_error << " %, F " << 100 * m.F_error << " %, strain " << 100 * m.strain_error << " %";
  return out.str();
}

void ErrorAccumulator::add(const double centroid[3], const double X[3], const double x_ref[3], const double x_approx[3],
                           const double v_ref[3], const double v_approx[3], const double F_ref[9],
                           const double F_approx[9]) {
  for (int k = 0; k < 3; ++k) {
    const double dx = x_approx[k] - x_ref[k];
    position_misfit_ += dx * dx;
    position_norm_ += (x_ref[k] - centroid[k]) * (x_ref[k] - centroid[k]);
    displacement_norm_ += (x_ref[k] - X[k]) * (x_ref[k] - X[k]);
    const double dv = v_approx[k] - v_ref[k];
    velocity_misfit_ += dv * dv;
    velocity_norm_ += v_ref[k] * v_ref[k];
  }
  for (int i = 0; i < 9; ++i) {
    const double dF = F_approx[i] - F_ref[i];
    const double strain = F_ref[i] - (i % 4 == 0 ? 1.0 : 0.0);
    F_misfit_ += dF * dF;
    F_norm_ += F_ref[i] * F_ref[i];
    strain_norm_ += strain * strain;
  }
}

void ErrorAccumulator::merge(const ErrorAccumulator& o) {
  position_misfit_ += o.position_misfit_;
  position_norm_ += o.position_norm_;
  displacement_norm_ += o.displacement_norm_;
  velocity_misfit_ += o.velocity_misfit_;
  velocity_norm_ += o.velocity_norm_;
  F_misfit_ += o.F_misfit_;
  F_norm_ += o.F_norm_;
  strain_norm_ += o.strain_norm_;
}

ErrorMetrics ErrorAccumulator::metrics() const {
  ErrorMetrics m;
  m.position_error = ratio(position_misfit_, position_norm_);
  m.displacement_error = ratio(position_misfit_, displacement_norm_);
  m.velocity_error = ratio(velocity_misfit_, velocity_norm_);
  m.F_error = ratio(F_misfit_, F_norm_);
  m.strain_error = ratio(F_misfit_, strain_norm_);
  return m;
}

}  // namespace mpmrom
