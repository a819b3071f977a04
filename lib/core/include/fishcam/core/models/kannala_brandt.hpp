#pragma once

#include "fishcam/core/models/model_base.hpp"

namespace fishcam {

// OpenCV's fisheye model: rho = f * theta * (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8).
// Parameters in the order f, k1, k2, k3, k4. OpenCV's fx, fy map to f = fx, a_y = fy / fx.
template <typename Scalar>
class KannalaBrandt {
 public:
  static constexpr std::string_view kName = "kannala-brandt";
  static constexpr std::array<std::string_view, 5> kParamNames{"f", "k1", "k2", "k3", "k4"};

  KannalaBrandt() = default;
  KannalaBrandt(Scalar f, Scalar k1, Scalar k2, Scalar k3, Scalar k4) : p_{f, k1, k2, k3, k4} {}
  explicit KannalaBrandt(const Scalar* p, int = 5) : p_{p[0], p[1], p[2], p[3], p[4]} {}

  std::string invalid() const { return ""; }
  Scalar rho(const Scalar& theta) const {
    const Scalar t2 = theta * theta;
    const Scalar poly = Scalar(1) + t2 * (p_[1] + t2 * (p_[2] + t2 * (p_[3] + t2 * p_[4])));
    return p_[0] * theta * poly;
  }
  Scalar drho(const Scalar& theta) const {
    const Scalar t2 = theta * theta;
    const Scalar d = Scalar(1) + t2 * (Scalar(3) * p_[1] +
                                       t2 * (Scalar(5) * p_[2] + t2 * (Scalar(7) * p_[3] + t2 * Scalar(9) * p_[4])));
    return p_[0] * d;
  }
  Scalar rho(const Scalar& theta, Scalar* drho) const {
    const Scalar t2 = theta * theta;
    const Scalar poly = Scalar(1) + t2 * (p_[1] + t2 * (p_[2] + t2 * (p_[3] + t2 * p_[4])));
    const Scalar d = Scalar(1) + t2 * (Scalar(3) * p_[1] +
                                       t2 * (Scalar(5) * p_[2] + t2 * (Scalar(7) * p_[3] + t2 * Scalar(9) * p_[4])));
    *drho = p_[0] * d;
    return p_[0] * theta * poly;
  }
  static constexpr double theta_limit() { return std::numbers::pi; }
  static constexpr bool limit_is_open() { return false; }
  KannalaBrandt scaled(const Scalar& s) const {
    KannalaBrandt out = *this;
    out.p_[0] = out.p_[0] * s;
    return out;
  }
  // rho is an odd polynomial of degree 9 in theta.
  std::vector<Scalar> power_coefficients() const {
    std::vector<Scalar> c(10, Scalar(0));
    c[1] = p_[0];
    for (int i = 1; i <= 4; ++i) c[2 * i + 1] = p_[0] * p_[i];
    return c;
  }
  std::vector<Scalar> params() const { return {p_[0], p_[1], p_[2], p_[3], p_[4]}; }

  static std::vector<double> initial_params(double f, int) { return {f, 0, 0, 0, 0}; }
  // Linear after reparametrization: rho = f theta + (f k1) theta^3 + ...
  static void basis(double theta, int, double* g) {
    double power = theta;
    for (int j = 0; j < 5; ++j, power *= theta * theta) g[j] = power;
  }
  static std::vector<double> from_basis(const double* p, int) {
    return {p[0], p[1] / p[0], p[2] / p[0], p[3] / p[0], p[4] / p[0]};
  }

 private:
  Scalar p_[5]{Scalar(1), Scalar(0), Scalar(0), Scalar(0), Scalar(0)};
};

}  // namespace fishcam
