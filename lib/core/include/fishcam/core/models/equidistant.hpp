#pragma once

#include "fishcam/core/models/model_base.hpp"

namespace fishcam {

// rho = f * theta.
template <typename Scalar>
class Equidistant {
 public:
  static constexpr std::string_view kName = "equidistant";
  static constexpr std::array<std::string_view, 1> kParamNames{"f"};

  Equidistant() = default;
  explicit Equidistant(Scalar f) : f_(f) {}
  Equidistant(const Scalar* p, int) : f_(p[0]) {}

  std::string invalid() const { return ""; }  // f > 0: compute_domain's slope check
  Scalar rho(const Scalar& theta) const { return f_ * theta; }
  Scalar drho(const Scalar&) const { return f_; }
  Scalar theta_from_rho(const Scalar& rho) const { return rho / f_; }
  static constexpr double theta_limit() { return std::numbers::pi; }
  static constexpr bool limit_is_open() { return false; }
  Equidistant scaled(const Scalar& s) const { return Equidistant(f_ * s); }
  // Eq. 13: f = rho / theta.
  static Equidistant from_paper(double rho, double theta) { return Equidistant(Scalar(rho / theta)); }
  std::vector<Scalar> power_coefficients() const { return {Scalar(0), f_}; }
  std::vector<Scalar> params() const { return {f_}; }
  const Scalar& f() const { return f_; }

  static std::vector<double> initial_params(double f, int) { return {f}; }
  static void basis(double theta, int, double* g) { g[0] = theta; }
  static std::vector<double> from_basis(const double* p, int) { return {p[0]}; }

 private:
  Scalar f_{1};
};

}  // namespace fishcam
