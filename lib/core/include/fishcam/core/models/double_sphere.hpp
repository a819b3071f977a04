#pragma once

#include "fishcam/core/models/model_base.hpp"

namespace fishcam {

// Double sphere model (Usenko et al. 2018): the ray is moved by xi along z and
// projected with the unified model in the alpha form:
//   rho = f sin(theta) / (alpha d + (1 - alpha) (xi + cos(theta))),
//   d = sqrt(sin^2(theta) + (xi + cos(theta))^2), parameters f, xi in (-1, 1), alpha in [0, 1].
// Valid while the moved ray's direction q satisfies cos(q) > -w (w as in the EUCM):
// the moved direction grows with theta for |xi| < 1, so theta_max is where cos(q) = -w
// (a pole for alpha <= 1/2, open; a fold beyond, closed). basalt's check
// z > -w2 |P| is the same bound for alpha >= 1/2 and a stricter one below.
template <typename Scalar>
class DoubleSphere {
 public:
  static constexpr std::string_view kName = "double-sphere";
  static constexpr std::array<std::string_view, 3> kParamNames{"f", "xi", "alpha"};

  DoubleSphere() = default;
  DoubleSphere(Scalar f, Scalar xi, Scalar alpha) : f_(f), xi_(xi), alpha_(alpha) {}
  DoubleSphere(const Scalar* p, int) : f_(p[0]), xi_(p[1]), alpha_(p[2]) {}

  std::string invalid() const {
    const std::string x = detail::require(double(xi_) > -1 && double(xi_) < 1, "xi must be in (-1, 1)");
    return !x.empty() ? x : detail::require(double(alpha_) >= 0 && double(alpha_) <= 1, "alpha must be in [0, 1]");
  }
  Scalar rho(const Scalar& theta) const {
    using std::cos;
    using std::sin;
    using std::sqrt;
    const Scalar s = sin(theta), a = xi_ + cos(theta);
    return f_ * s / (alpha_ * sqrt(s * s + a * a) + (Scalar(1) - alpha_) * a);
  }
  Scalar drho(const Scalar& theta) const {
    using std::cos;
    using std::sin;
    using std::sqrt;
    const Scalar s = sin(theta), c = cos(theta), a = xi_ + c;
    const Scalar d = sqrt(s * s + a * a);
    const Scalar den = alpha_ * d + (Scalar(1) - alpha_) * a;
    // (c D - s D') / D^2 with D' = -s (alpha xi / d + 1 - alpha).
    return f_ * (c * den + s * s * (alpha_ * xi_ / d + Scalar(1) - alpha_)) / (den * den);
  }
  Scalar theta_from_rho(const Scalar& rho) const {
    using std::atan2;
    using std::sqrt;
    const Scalar r = rho / f_, r2 = r * r;
    const Scalar mz =
        (Scalar(1) - alpha_ * alpha_ * r2) /
        (alpha_ * detail::sqrt_nonnegative(Scalar(1) - (Scalar(2) * alpha_ - Scalar(1)) * r2) + Scalar(1) - alpha_);
    const Scalar k = (mz * xi_ + detail::sqrt_nonnegative(mz * mz + (Scalar(1) - xi_ * xi_) * r2)) / (mz * mz + r2);
    return detail::newton_polish(*this, atan2(k * r, k * mz - xi_), rho);
  }
  double theta_limit() const {
    return double(alpha_) == 0.5 ? std::numbers::pi
                                 : detail::theta_of_shifted_direction(double(xi_), detail::alpha_w1(double(alpha_)));
  }
  bool limit_is_open() const { return double(alpha_) <= 0.5; }
  DoubleSphere scaled(const Scalar& s) const { return DoubleSphere(f_ * s, xi_, alpha_); }
  std::vector<Scalar> params() const { return {f_, xi_, alpha_}; }
  UnifiedForm unified_form() const { return {double(f_), double(xi_), double(alpha_), 1, 0, 0}; }

  // rho'(0) = f / (1 + xi).
  static std::vector<double> initial_params(double f, int) { return {f, 0, 0.5}; }
  static std::vector<std::vector<double>> fit_starts(double f) {
    return {{0.8 * f, -0.2, 0.6}, {1.2 * f, 0.2, 0.6}, {0.8 * f, -0.2, 0.4}, {1.2 * f, 0.2, 0.4}};
  }
  static std::pair<double, double> param_bounds(int i) {
    if (i == 1) return {-0.999, 0.999};
    if (i == 2) return {0.0, 1.0};
    return {0.0, detail::kInf};
  }

 private:
  Scalar f_{1}, xi_{0}, alpha_{0};
};

}  // namespace fishcam
