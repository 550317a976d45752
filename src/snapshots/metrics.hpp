// The error metrics of SPEC.md (position, displacement, velocity, F and strain errors) of an approximation against a
// full-order reference, accumulated point by point over all material points and output times of a run.
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace mpmrom {

struct ErrorMetrics {
  double position_error = 0;      // |x~ - x| / |x - c|, c the centroid of the reference configuration
  double displacement_error = 0;  // |x~ - x| / |x - X|
  double velocity_error = 0;      // |v~ - v| / |v|
  double F_error = 0;             // |F~ - F| / |F|
  double strain_error = 0;        // |F~ - F| / |F - I|
};

nlohmann::json to_json(const ErrorMetrics& metrics);
// "position 0.052 %, displacement 1.2 %, velocity 3.4 %, F 0.021 %, strain 2.1 %"
std::string to_percent_string(const ErrorMetrics& metrics);

// Sums of squares behind the metrics; add() every (point, time) of one or more runs, then metrics(). A ratio whose
// denominator is zero (a run without motion) is reported as 0 if its numerator is zero too, else infinity.
class ErrorAccumulator {
 public:
  // centroid: c of the position error. Each pointer is to 3 (vectors) or 9 (row-major matrices) values.
  void add(const double centroid[3], const double X[3], const double x_ref[3], const double x_approx[3],
           const double v_ref[3], const double v_approx[3], const double F_ref[9], const double F_approx[9]);
  void merge(const ErrorAccumulator& other);
  ErrorMetrics metrics() const;

 private:
  double position_misfit_ = 0, position_norm_ = 0, displacement_norm_ = 0;
  double velocity_misfit_ = 0, velocity_norm_ = 0;
  double F_misfit_ = 0, F_norm_ = 0, strain_norm_ = 0;
};

}  // namespace mpmrom
