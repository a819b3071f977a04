#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "fishcam/testing/testing.hpp"

namespace fishcam::testing {
namespace {

// sum_i c[i] x^i, or with absolute_terms sum_i |c[i] x^i| (the scale of a residual).
double horner(std::span<const double> c, double x, bool absolute_terms) {
  double sum = 0;
  for (size_t i = c.size(); i-- > 0;)
    sum = sum * (absolute_terms ? std::abs(x) : x) + (absolute_terms ? std::abs(c[i]) : c[i]);
  return sum;
}

}  // namespace

double algebraic_theta(std::span<const double> power_coefficients, double rho, const ValidDomain& domain) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (!domain.contains_rho(rho)) return nan;
  std::vector<double> shifted(power_coefficients.begin(), power_coefficients.end());
  shifted[0] -= rho;
  // Tolerances: a double root at a fold splits into a complex pair of size ~sqrt(eps).
  const double slack = 1e-6 * std::max(1.0, domain.theta_max);
  double best = nan, best_residual = std::numeric_limits<double>::infinity();
  for (const auto& z : polynomial_roots(shifted)) {
    if (std::abs(z.imag()) > 1e-6 * std::max(1.0, std::abs(z))) continue;
    if (z.real() < -slack || z.real() > domain.theta_max + slack) continue;
    const double theta = std::clamp(z.real(), 0.0, domain.theta_max);
    const double residual =
        std::abs(horner(shifted, theta, false)) / std::max(1.0, horner(power_coefficients, theta, true));
    if (residual < best_residual) best = theta, best_residual = residual;
  }
  return best;
}

}  // namespace fishcam::testing
