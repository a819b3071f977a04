#pragma once

#include "fishcam/core/models/model_base.hpp"

namespace fishcam {

// Unified camera model (UCM) in the xi form Kalibr's `omni` uses:
//   rho = f sin(theta) / (xi + cos(theta)),  parameters f, xi (xi >= 0).
// xi = 0 is the pinhole, xi = 1 the stereographic model with f = 2 f_stereographic.
// Valid: theta < acos(-xi) for xi <= 1 (a pole); theta <= acos(-1/xi) for xi > 1 (a fold).
// basalt's alpha form (fx x / (alpha d + (1 - alpha) z)): xi = alpha / (1 - alpha),
// f = f_alpha / (1 - alpha).
template <typename Scalar>
class Unified {
 public:
  static constexpr std::string_view kName = "unified";
  static constexpr std::array<std::string_view, 2> kParamNames{"f", "xi"};

  Unified() = default;
  Unified(Scalar f, Scalar xi) : f_(f), xi_(xi) {}
  Unified(const Scalar* p, int) : f_(p[0]), xi_(p[1]) {}

  std::string invalid() const { return detail::require(double(xi_) >= 0, "xi must be >= 0"); }
  // xi + cos(theta) written as (xi - 1) + 2 cos^2(theta/2): exact near pi for xi = 1.
  Scalar denominator(const Scalar& theta) const {
    using std::cos;
    const Scalar h = cos(theta / Scalar(2));
    return (xi_ - Scalar(1)) + Scalar(2) * h * h;
  }
  Scalar rho(const Scalar& theta) const {
    using std::sin;
    return f_ * sin(theta) / denominator(theta);
  }
  Scalar drho(const Scalar& theta) const {
    using std::cos;
    const Scalar d = denominator(theta);
    return f_ * (Scalar(1) + xi_ * cos(theta)) / (d * d);
  }
  // The normalised radius r = rho / f back to the unit ray's angle (Mei's lifting).
  static Scalar theta_from_radius(const Scalar& r, const Scalar& xi) {
    using std::atan2;
    using std::sqrt;
    const Scalar r2 = r * r;
    const Scalar k = (xi + detail::sqrt_nonnegative(Scalar(1) + (Scalar(1) - xi * xi) * r2)) / (Scalar(1) + r2);
    return atan2(k * r, k - xi);
  }
  Scalar theta_from_rho(const Scalar& rho) const {
    return detail::newton_polish(*this, theta_from_radius(rho / f_, xi_), rho);
  }
  double theta_limit() const {
    const double xi = double(xi_);
    return xi <= 1 ? std::acos(-xi) : std::acos(-1 / xi);
  }
  bool limit_is_open() const { return double(xi_) <= 1; }
  Unified scaled(const Scalar& s) const { return Unified(f_ * s, xi_); }
  std::vector<Scalar> params() const { return {f_, xi_}; }
  UnifiedForm unified_form() const { return {double(f_), double(xi_), 0, 1, 0, 0}; }

  // rho'(0) = f / (1 + xi).
  static std::vector<double> initial_params(double f, int) { return {2 * f, 1}; }
  static std::vector<std::vector<double>> fit_starts(double f) { return {{1.5 * f, 0.5}, {2 * f, 1}, {3 * f, 2}}; }
  static std::pair<double, double> param_bounds(int i) {
    return i == 1 ? std::pair{0.0, 1e3} : std::pair{0.0, detail::kInf};
  }

 private:
  Scalar f_{1}, xi_{0};
};

}  // namespace fishcam
