#pragma once

#include "fishcam/core/models/model_base.hpp"

namespace fishcam {

// Extended unified camera model (EUCM, Khomenko et al. 2016):
//   rho = f sin(theta) / (alpha sqrt(beta sin^2(theta) + cos^2(theta)) + (1 - alpha) cos(theta)),
// parameters f, alpha in [0, 1], beta > 0. beta = 1 is the unified model in basalt's alpha form.
// With w = alpha / (1 - alpha) (alpha <= 1/2: a pole, open) or (1 - alpha) / alpha
// (alpha > 1/2: a fold, closed), valid for cos(theta) > -w sqrt(beta sin^2 + cos^2), i.e.
// cos^2(theta_max) = w^2 beta / (1 - w^2 + w^2 beta).
template <typename Scalar>
class ExtendedUnified {
 public:
  static constexpr std::string_view kName = "extended-unified";
  static constexpr std::array<std::string_view, 3> kParamNames{"f", "alpha", "beta"};

  ExtendedUnified() = default;
  ExtendedUnified(Scalar f, Scalar alpha, Scalar beta) : f_(f), alpha_(alpha), beta_(beta) {}
  ExtendedUnified(const Scalar* p, int) : f_(p[0]), alpha_(p[1]), beta_(p[2]) {}

  std::string invalid() const {
    const std::string a = detail::require(double(alpha_) >= 0 && double(alpha_) <= 1, "alpha must be in [0, 1]");
    return !a.empty() ? a : detail::require(double(beta_) > 0, "beta must be > 0");
  }
  Scalar rho(const Scalar& theta) const {
    using std::cos;
    using std::sin;
    using std::sqrt;
    const Scalar s = sin(theta), c = cos(theta);
    return f_ * s / (alpha_ * sqrt(beta_ * s * s + c * c) + (Scalar(1) - alpha_) * c);
  }
  // rho' = f ((1 - alpha) + alpha cos / d) / D^2 with d = sqrt(beta sin^2 + cos^2).
  Scalar drho(const Scalar& theta) const {
    using std::cos;
    using std::sin;
    using std::sqrt;
    const Scalar s = sin(theta), c = cos(theta);
    const Scalar d = sqrt(beta_ * s * s + c * c);
    const Scalar den = alpha_ * d + (Scalar(1) - alpha_) * c;
    return f_ * ((Scalar(1) - alpha_) + alpha_ * c / d) / (den * den);
  }
  // Usenko et al. 2018, eq. (the EUCM unprojection): m_z from r = rho / f.
  Scalar theta_from_rho(const Scalar& rho) const {
    using std::atan2;
    using std::sqrt;
    const Scalar r = rho / f_, r2 = r * r;
    const Scalar mz = (Scalar(1) - beta_ * alpha_ * alpha_ * r2) /
                      (alpha_ * detail::sqrt_nonnegative(Scalar(1) - (Scalar(2) * alpha_ - Scalar(1)) * beta_ * r2) +
                       (Scalar(1) - alpha_));
    return detail::newton_polish(*this, atan2(r, mz), rho);
  }
  double theta_limit() const {
    const double alpha = double(alpha_), beta = double(beta_);
    if (alpha == 0.5) return std::numbers::pi;
    const double w = detail::alpha_w1(alpha), w2 = w * w;
    return std::acos(-std::sqrt(w2 * beta / (1 - w2 + w2 * beta)));
  }
  bool limit_is_open() const { return double(alpha_) <= 0.5; }
  ExtendedUnified scaled(const Scalar& s) const { return ExtendedUnified(f_ * s, alpha_, beta_); }
  std::vector<Scalar> params() const { return {f_, alpha_, beta_}; }
  UnifiedForm unified_form() const { return {double(f_), 0, double(alpha_), double(beta_), 0, 0}; }

  static std::vector<double> initial_params(double f, int) { return {f, 0.5, 1}; }
  static std::vector<std::vector<double>> fit_starts(double f) { return {{f, 0.5, 1}, {f, 0.6, 1.2}, {f, 0.4, 0.8}}; }
  static std::pair<double, double> param_bounds(int i) {
    if (i == 1) return {0.0, 1.0};
    if (i == 2) return {1e-6, 1e3};
    return {0.0, detail::kInf};
  }

 private:
  Scalar f_{1}, alpha_{0}, beta_{1};
};

}  // namespace fishcam
