// Radial projection models rho(theta): image distance from the principal point
// (in pixel-scale units, see docs/conventions.md) as a function of the angle of
// incidence theta.
//
// One small class per model, templated on the scalar type so that Ceres can
// differentiate through them (ceres::Jet). Math calls are unqualified after a
// `using std::...` so that ADL picks the Jet overloads.
//
// Each model provides
//   rho(theta), drho(theta)          the model and its analytic derivative
//   (optionally rho(theta, &drho)    both at once, where that is cheaper)
//   kThetaLimit, kLimitIsOpen        where the model itself stops (pinhole: theta < pi/2)
//   scaled(s)                        the model for s * rho(theta), exactly
//   params()                         parameters in the documented order
// and the closed-form models also theta_from_rho(rho).
#pragma once

#include <cmath>
#include <numbers>
#include <string_view>
#include <vector>

namespace fishcam {

// rho = k1*theta + k2*theta^2 + ... + kN*theta^N (no constant term). WoodScape: N = 4.
template <typename Scalar>
class Polynomial {
 public:
  static constexpr std::string_view kName = "polynomial";
  static constexpr double kThetaLimit = std::numbers::pi;
  static constexpr bool kLimitIsOpen = false;

  Polynomial() = default;
  explicit Polynomial(std::vector<Scalar> k) : k_(std::move(k)) {}
  Polynomial(const Scalar* k, int n) : k_(k, k + n) {}

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

 private:
  std::vector<Scalar> k_{Scalar(1)};
};

// rho = f * theta.
template <typename Scalar>
class Equidistant {
 public:
  static constexpr std::string_view kName = "equidistant";
  static constexpr double kThetaLimit = std::numbers::pi;
  static constexpr bool kLimitIsOpen = false;

  Equidistant() = default;
  explicit Equidistant(Scalar f) : f_(f) {}

  Scalar rho(const Scalar& theta) const { return f_ * theta; }
  Scalar drho(const Scalar&) const { return f_; }
  Scalar theta_from_rho(const Scalar& rho) const { return rho / f_; }
  Equidistant scaled(const Scalar& s) const { return Equidistant(f_ * s); }
  std::vector<Scalar> power_coefficients() const { return {Scalar(0), f_}; }
  std::vector<Scalar> params() const { return {f_}; }
  const Scalar& f() const { return f_; }

 private:
  Scalar f_{1};
};

// rho = 2 f tan(theta / 2); defined up to (not including) theta = pi.
template <typename Scalar>
class Stereographic {
 public:
  static constexpr std::string_view kName = "stereographic";
  static constexpr double kThetaLimit = std::numbers::pi;
  static constexpr bool kLimitIsOpen = true;

  Stereographic() = default;
  explicit Stereographic(Scalar f) : f_(f) {}

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
  Stereographic scaled(const Scalar& s) const { return Stereographic(f_ * s); }
  std::vector<Scalar> params() const { return {f_}; }
  const Scalar& f() const { return f_; }

 private:
  Scalar f_{1};
};

// rho = f tan(theta); defined for theta < pi/2 only.
template <typename Scalar>
class Pinhole {
 public:
  static constexpr std::string_view kName = "pinhole";
  static constexpr double kThetaLimit = std::numbers::pi / 2;
  static constexpr bool kLimitIsOpen = true;

  Pinhole() = default;
  explicit Pinhole(Scalar f) : f_(f) {}

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
  Pinhole scaled(const Scalar& s) const { return Pinhole(f_ * s); }
  std::vector<Scalar> params() const { return {f_}; }
  const Scalar& f() const { return f_; }

 private:
  Scalar f_{1};
};

// OpenCV's fisheye model: rho = f * theta * (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8).
// Parameters in the order f, k1, k2, k3, k4. OpenCV's fx, fy map to f = fx, a_y = fy / fx.
template <typename Scalar>
class KannalaBrandt {
 public:
  static constexpr std::string_view kName = "kannala-brandt";
  static constexpr double kThetaLimit = std::numbers::pi;
  static constexpr bool kLimitIsOpen = false;
  static constexpr int kNumParams = 5;

  KannalaBrandt() = default;
  KannalaBrandt(Scalar f, Scalar k1, Scalar k2, Scalar k3, Scalar k4) : p_{f, k1, k2, k3, k4} {}
  explicit KannalaBrandt(const Scalar* p) : p_{p[0], p[1], p[2], p[3], p[4]} {}

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

 private:
  Scalar p_[5]{Scalar(1), Scalar(0), Scalar(0), Scalar(0), Scalar(0)};
};

template <class Model>
concept ClosedFormInverse = requires(const Model& m, double r) { m.theta_from_rho(r); };

template <class Model>
concept FusedDerivative = requires(const Model& m, double t, double* d) { m.rho(t, d); };

// rho and drho/dtheta together, fused where the model offers it.
template <class Model, typename Scalar>
Scalar rho_and_drho(const Model& model, const Scalar& theta, Scalar* drho) {
  if constexpr (FusedDerivative<Model>) {
    return model.rho(theta, drho);
  } else {
    *drho = model.drho(theta);
    return model.rho(theta);
  }
}

template <class Model>
concept PolynomialInTheta = requires(const Model& m) { m.power_coefficients(); };

}  // namespace fishcam
