#pragma once

#include "fishcam/core/models/model_base.hpp"

namespace fishcam {

// rho = 2 f tan(theta / 2); defined up to (not including) theta = pi.
template <typename Scalar>
class Stereographic {
 public:
  static constexpr std::string_view kName = "stereographic";
  static constexpr std::array<std::string_view, 1> kParamNames{"f"};

  Stereographic() = default;
  explicit Stereographic(Scalar f) : f_(f) {}
  Stereographic(const Scalar* p, int) : f_(p[0]) {}

  std::string invalid() const { return ""; }
  Scalar rho(const Scalar& theta) const {
    using std::tan;
    return Scalar(2) * f_ * tan(theta / Scalar(2));
  }
  Scalar drho(const Scalar& theta) const {
    using std::cos;
    const Scalar c = cos(theta / Scalar(2));
    return f_ / (c * c);
  }
  Scalar theta_from_rho(const Scalar& rho) const {
    using std::atan;
    return Scalar(2) * atan(rho / (Scalar(2) * f_));
  }
  static constexpr double theta_limit() { return std::numbers::pi; }
  static constexpr bool limit_is_open() { return true; }
  Stereographic scaled(const Scalar& s) const { return Stereographic(f_ * s); }
  // The plane of the stereographic projection, u = 2 tan(theta / 2) (mrcal's splined
  // models displace it; fishcam/core/mrcal_lens.hpp).
  double focal() const { return double(f_); }
  static double plane_radius(double theta, double* derivative) {
    const double c = std::cos(theta / 2);
    *derivative = 1 / (c * c);
    return 2 * std::tan(theta / 2);
  }
  static double theta_of_plane_radius(double r) { return 2 * std::atan(r / 2); }
  static double radial_factor(double, double* derivative) { return *derivative = 0, 1.0; }
  // Eq. 14: f = rho / (2 tan(theta / 2)).
  static Stereographic from_paper(double rho, double theta) {
    return Stereographic(Scalar(rho / (2 * std::tan(theta / 2))));
  }
  std::vector<Scalar> params() const { return {f_}; }
  const Scalar& f() const { return f_; }
  UnifiedForm unified_form() const { return {2 * double(f_), 1, 0, 1, 0, 0}; }

  static std::vector<double> initial_params(double f, int) { return {f}; }
  static void basis(double theta, int, double* g) { g[0] = 2 * std::tan(theta / 2); }
  static std::vector<double> from_basis(const double* p, int) { return {p[0]}; }

 private:
  Scalar f_{1};
};

}  // namespace fishcam
