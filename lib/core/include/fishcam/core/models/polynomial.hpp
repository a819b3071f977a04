#pragma once

#include "fishcam/core/models/model_base.hpp"

namespace fishcam {

// rho = k1*theta + k2*theta^2 + ... + kN*theta^N (no constant term). WoodScape: N = 4.
template <typename Scalar>
class Polynomial {
 public:
  static constexpr std::string_view kName = "polynomial";
  static constexpr bool kTakesOrder = true;
  static constexpr std::array<std::string_view, 0> kParamNames{};  // k1..kN: any count
  static constexpr int kMaxOrder = 64;  // coefficients a file may give (fits stop at 12, fit.hpp)

  Polynomial() = default;
  explicit Polynomial(std::vector<Scalar> k) : k_(std::move(k)) {}
  Polynomial(const Scalar* k, int n) : k_(k, k + n) {}

  std::string invalid() const {
    return detail::require(!k_.empty() && k_.size() <= size_t(kMaxOrder), "expected 1 to 64 coefficients (k1..kN)");
  }
  Scalar rho(const Scalar& theta) const {
    // Horner on k1 + k2*t + ... + kN*t^(N-1), then times theta.
    Scalar r = k_.back();
    for (int i = static_cast<int>(k_.size()) - 2; i >= 0; --i) r = r * theta + k_[i];
    return r * theta;
  }
  Scalar drho(const Scalar& theta) const {
    const int n = static_cast<int>(k_.size());
    Scalar d = Scalar(double(n)) * k_[n - 1];
    for (int i = n - 2; i >= 0; --i) d = d * theta + Scalar(double(i + 1)) * k_[i];
    return d;
  }
  // rho and drho/dtheta in one Horner pass (the solver's inner loop):
  // rho = t p(t) with p = k1 + k2 t + ..., rho' = p(t) + t p'(t).
  Scalar rho(const Scalar& theta, Scalar* drho) const {
    Scalar p = k_.back(), dp = Scalar(0);
    for (int i = static_cast<int>(k_.size()) - 2; i >= 0; --i) {
      dp = dp * theta + p;
      p = p * theta + k_[i];
    }
    *drho = p + theta * dp;
    return p * theta;
  }
  static constexpr double theta_limit() { return std::numbers::pi; }
  static constexpr bool limit_is_open() { return false; }
  Polynomial scaled(const Scalar& s) const {
    Polynomial out = *this;
    for (auto& k : out.k_) k = k * s;
    return out;
  }
  // Coefficients c[i] of theta^i, i = 0..N (c[0] = 0), for the algebraic tools.
  std::vector<Scalar> power_coefficients() const {
    std::vector<Scalar> c(k_.size() + 1, Scalar(0));
    for (size_t i = 0; i < k_.size(); ++i) c[i + 1] = k_[i];
    return c;
  }
  const std::vector<Scalar>& params() const { return k_; }
  int order() const { return static_cast<int>(k_.size()); }

  static std::vector<double> initial_params(double f, int order) {
    std::vector<double> k(size_t(std::max(order, 1)), 0.0);
    k[0] = f;
    return k;
  }
  static void basis(double theta, int n, double* g) {
    double power = theta;
    for (int j = 0; j < n; ++j, power *= theta) g[j] = power;
  }
  static std::vector<double> from_basis(const double* p, int n) { return {p, p + n}; }

 private:
  std::vector<Scalar> k_{Scalar(1)};
};

}  // namespace fishcam
