#pragma once

#include "fishcam/core/models/model_base.hpp"
#include "fishcam/core/models/unified.hpp"

namespace fishcam {

// Mei's model (camodocal MEI, OpenCV omnidir) with zero tangential terms: the
// unified model's normalised radius r = sin(theta) / (xi + cos(theta)), distorted
// radially: rho = f r (1 + k1 r^2 + k2 r^4); parameters f, xi (>= 0), k1, k2.
// Valid: the unified model's domain, up to the first fold of the distortion
// (1 + 3 k1 r^2 + 5 k2 r^4 = 0), closed there.
template <typename Scalar>
class Mei {
 public:
  static constexpr std::string_view kName = "mei";
  static constexpr std::array<std::string_view, 4> kParamNames{"f", "xi", "k1", "k2"};

  Mei() = default;
  Mei(Scalar f, Scalar xi, Scalar k1, Scalar k2) : f_(f), xi_(xi), k1_(k1), k2_(k2) {}
  Mei(const Scalar* p, int) : f_(p[0]), xi_(p[1]), k1_(p[2]), k2_(p[3]) {}

  std::string invalid() const { return detail::require(double(xi_) >= 0, "xi must be >= 0"); }
  Scalar radius(const Scalar& theta) const { return Unified<Scalar>(Scalar(1), xi_).rho(theta); }
  Scalar rho(const Scalar& theta) const {
    const Scalar r = radius(theta), r2 = r * r;
    return f_ * r * (Scalar(1) + r2 * (k1_ + r2 * k2_));
  }
  Scalar drho(const Scalar& theta) const {
    const Scalar r = radius(theta), r2 = r * r;
    return f_ * (Scalar(1) + r2 * (Scalar(3) * k1_ + r2 * Scalar(5) * k2_)) *
           Unified<Scalar>(Scalar(1), xi_).drho(theta);
  }
  double theta_limit() const {
    const Unified<double> ucm(1.0, double(xi_));
    double limit = ucm.theta_limit();
    // The distortion's fold: the smallest x = r^2 > 0 with 1 + 3 k1 x + 5 k2 x^2 = 0.
    const double a = 5 * double(k2_), b = 3 * double(k1_);
    double x = detail::kInf;
    if (a == 0) {
      if (b < 0) x = -1 / b;
    } else {
      const double disc = b * b - 4 * a;
      if (disc >= 0) {
        const double q = -0.5 * (b + std::copysign(std::sqrt(disc), b));
        for (double root : {q / a, 1 / q}) {  // 1 / q = c / q with c = 1
          if (root > 0 && std::isfinite(root)) x = std::min(x, root);
        }
      }
    }
    if (std::isfinite(x)) {
      const double r_max = limit_is_open_ucm() ? detail::kInf : ucm.rho(limit);
      if (std::sqrt(x) < r_max) limit = Unified<double>::theta_from_radius(std::sqrt(x), double(xi_));
    }
    return limit;
  }
  bool limit_is_open() const {
    return limit_is_open_ucm() && theta_limit() == Unified<double>(1.0, double(xi_)).theta_limit();
  }
  Mei scaled(const Scalar& s) const { return Mei(f_ * s, xi_, k1_, k2_); }
  std::vector<Scalar> params() const { return {f_, xi_, k1_, k2_}; }
  UnifiedForm unified_form() const { return {double(f_), double(xi_), 0, 1, double(k1_), double(k2_)}; }

  // The undistorted plane m = (X, Y) / (Z + xi |P|) (fishcam/core/tangential.hpp): R = 1 + k1 s + k2 s^2.
  static constexpr bool kTakesTangentialTerms = true;
  // m and the focal length for a camera-frame point, generic in the scalar type (a
  // calibration solving tangential terms differentiates them).
  Scalar plane_point(const Scalar* point, Scalar* m) const {
    using std::sqrt;
    const Scalar d = point[2] + xi_ * sqrt(point[0] * point[0] + point[1] * point[1] + point[2] * point[2]);
    m[0] = point[0] / d, m[1] = point[1] / d;
    return f_;
  }
  double focal() const { return double(f_); }
  double plane_radius(double theta, double* derivative) const {
    const Unified<double> ucm(1.0, double(xi_));
    *derivative = ucm.drho(theta);
    return ucm.rho(theta);
  }
  double theta_of_plane_radius(double r) const { return Unified<double>::theta_from_radius(r, double(xi_)); }
  double radial_factor(double s, double* derivative) const {
    *derivative = double(k1_) + 2 * double(k2_) * s;
    return 1 + s * (double(k1_) + s * double(k2_));
  }

  static std::vector<double> initial_params(double f, int) { return {2 * f, 1, 0, 0}; }
  static std::vector<std::vector<double>> fit_starts(double f) {
    return {{1.5 * f, 0.5, 0, 0}, {2 * f, 1, 0, 0}, {3 * f, 2, 0, 0}};
  }
  static std::pair<double, double> param_bounds(int i) {
    if (i == 1) return {0.0, 1e3};
    if (i == 0) return {0.0, detail::kInf};
    return {-detail::kInf, detail::kInf};
  }

 private:
  bool limit_is_open_ucm() const { return double(xi_) <= 1; }
  Scalar f_{1}, xi_{0}, k1_{0}, k2_{0};
};

}  // namespace fishcam
