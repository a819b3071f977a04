#pragma once

#include "fishcam/core/models/model_base.hpp"

namespace fishcam {

// rho = f tan(theta); defined for theta < pi/2 only.
template <typename Scalar>
class Pinhole {
 public:
  static constexpr std::string_view kName = "pinhole";
  static constexpr std::array<std::string_view, 1> kParamNames{"f"};

  Pinhole() = default;
  explicit Pinhole(Scalar f) : f_(f) {}
  Pinhole(const Scalar* p, int) : f_(p[0]) {}

  std::string invalid() const { return ""; }
  Scalar rho(const Scalar& theta) const {
    using std::tan;
    return f_ * tan(theta);
  }
  Scalar drho(const Scalar& theta) const {
    using std::cos;
    const Scalar c = cos(theta);
    return f_ / (c * c);
  }
  Scalar theta_from_rho(const Scalar& rho) const {
    using std::atan;
    return atan(rho / f_);
  }
  static constexpr double theta_limit() { return std::numbers::pi / 2; }
  static constexpr bool limit_is_open() { return true; }
  Pinhole scaled(const Scalar& s) const { return Pinhole(f_ * s); }
  std::vector<Scalar> params() const { return {f_}; }
  const Scalar& f() const { return f_; }
  UnifiedForm unified_form() const { return {double(f_), 0, 0, 1, 0, 0}; }
  // The undistorted plane m = (X, Y) / Z (fishcam/core/tangential.hpp).
  static constexpr bool kTakesTangentialTerms = true;
  // m and the focal length for a camera-frame point, generic in the scalar type (a
  // calibration solving tangential terms differentiates them).
  Scalar plane_point(const Scalar* point, Scalar* m) const {
    m[0] = point[0] / point[2], m[1] = point[1] / point[2];
    return f_;
  }
  double focal() const { return double(f_); }
  static double plane_radius(double theta, double* derivative) {
    const double c = std::cos(theta);
    *derivative = 1 / (c * c);
    return std::tan(theta);
  }
  static double theta_of_plane_radius(double r) { return std::atan(r); }
  static double radial_factor(double, double* derivative) { return *derivative = 0, 1.0; }

  static std::vector<double> initial_params(double f, int) { return {f}; }
  static void basis(double theta, int, double* g) { g[0] = std::tan(theta); }
  static std::vector<double> from_basis(const double* p, int) { return {p[0]}; }

 private:
  Scalar f_{1};
};

}  // namespace fishcam
