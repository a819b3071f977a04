#pragma once

#include "fishcam/core/models/model_base.hpp"

namespace fishcam {

// Scaramuzza's omnidirectional model (OCamCalib's calib_results.txt, camodocal
// SCARAMUZZA): the image point at distance rho from the centre sees the ray
// (rho cos(phi), rho sin(phi), -P(rho)) with P(rho) = a0 + a1 rho + ... + a4 rho^4
// (OCamCalib's `pol`, a0 < 0; fishcam's frame, z forward), so in closed form
//   theta(rho) = atan2(rho, -P(rho)),
// and rho(theta) is its inverse: the root of h(rho) = rho cos(theta) + P(rho) sin(theta)
// (h < 0 exactly where theta(rho) < theta), by bracketed Newton; for Jets one more
// Newton step in Jet arithmetic carries the derivatives (implicit function theorem).
// Parameters a0..a4 in OCamCalib's units (pixels): a file with fewer coefficients has
// the rest 0. Valid while theta(rho) increases: up to the first positive root rho_f of
// rho P'(rho) - P(rho) = -a0 + a2 rho^2 + 2 a3 rho^3 + 3 a4 rho^4 (closed there: theta(rho)
// turns back), else up to the ray's direction as rho grows without bound (open).
template <typename Scalar>
class OCam {
 public:
  static constexpr std::string_view kName = "ocam";
  static constexpr std::array<std::string_view, 5> kParamNames{"a0", "a1", "a2", "a3", "a4"};

  OCam() : OCam(std::array<Scalar, 5>{Scalar(-1), Scalar(0), Scalar(0), Scalar(0), Scalar(0)}) {}
  explicit OCam(const std::array<Scalar, 5>& a) : a_(a) {
    for (size_t i = 0; i < 5; ++i) v_[i] = detail::value_of(a[i]);
    locate_fold();
  }
  OCam(const Scalar* p, int) : OCam(std::array<Scalar, 5>{p[0], p[1], p[2], p[3], p[4]}) {}

  std::string invalid() const { return detail::require(v_[0] < 0, "a0 must be < 0 (the axis looks along -a0)"); }
  Scalar theta_from_rho(const Scalar& rho) const {
    using std::atan2;
    Scalar p = a_[4];
    for (int i = 3; i >= 0; --i) p = p * rho + a_[size_t(i)];
    return atan2(rho, -p);
  }
  Scalar rho(const Scalar& theta) const {
    using std::cos;
    using std::sin;
    const double r = solve_rho(detail::value_of(theta));
    if constexpr (std::is_arithmetic_v<Scalar>) {
      return r;
    } else {
      Scalar p = a_[4], dp = Scalar(0);  // P and P' at the constant r
      for (int i = 3; i >= 0; --i) dp = dp * r + p, p = p * r + a_[size_t(i)];
      const Scalar c = cos(theta), s = sin(theta);
      return Scalar(r) - (Scalar(r) * c + p * s) / (c + dp * s);
    }
  }
  // drho/dtheta = 1 / (dtheta/drho) = (rho^2 + P^2) / (rho P' - P).
  Scalar drho(const Scalar& theta) const {
    const Scalar r = rho(theta);
    Scalar p = a_[4], dp = Scalar(0);
    for (int i = 3; i >= 0; --i) dp = dp * r + p, p = p * r + a_[size_t(i)];
    return (r * r + p * p) / (r * dp - p);
  }
  double theta_limit() const { return theta_limit_; }
  bool limit_is_open() const { return !fold_rho_; }
  // s rho(theta): P_s(r) = s P(r / s), a_i -> a_i s^(1 - i).
  OCam scaled(const Scalar& s) const {
    std::array<Scalar, 5> a = a_;
    Scalar power = s;  // s^(1 - i)
    for (size_t i = 0; i < 5; ++i, power = power / s) a[i] = a[i] * power;
    return OCam(a);
  }
  std::vector<Scalar> params() const { return {a_.begin(), a_.end()}; }
  // P's coefficients a0..a4 (the float warp kernel's form: Newton on rho Pz + chi P(rho)).
  const std::array<double, 5>& ray_polynomial() const { return v_; }

  // Equidistant-like (P = -f + r^2 / (3 f): theta = r / f to third order) and
  // stereographic (P = -f + r^2 / (4 f), exactly) starts.
  static std::vector<double> initial_params(double f, int) { return {-f, 0, 1 / (3 * f), 0, 0}; }
  static std::vector<std::vector<double>> fit_starts(double f) {
    return {{-f, 0, 1 / (3 * f), 0, 0}, {-f, 0, 1 / (4 * f), 0, 0}, {-f, 0, 1 / (2 * f), 0, 0}};
  }
  static std::pair<double, double> param_bounds(int i) {
    if (i == 0) return {-detail::kInf, 0.0};
    return {-detail::kInf, detail::kInf};
  }

 private:
  static constexpr double kMaxRho = 1e9;  // px: no image reaches that far
  double h(double r, double c, double s, double* derivative) const {
    double p = v_[4], dp = 0;
    for (int i = 3; i >= 0; --i) dp = dp * r + p, p = p * r + v_[size_t(i)];
    *derivative = c + dp * s;
    return r * c + p * s;
  }
  void locate_fold() {
    const auto& a = v_;
    if (!(a[0] < 0) || !std::isfinite(a[0] + a[1] + a[2] + a[3] + a[4])) return;  // invalid(): not used
    const double g[5] = {-a[0], 0, a[2], 2 * a[3], 3 * a[4]};
    if (const std::optional<double> root = first_positive_root(g, kMaxRho)) {
      fold_rho_ = *root;
      theta_limit_ = std::atan2(*root, -(a[0] + *root * (a[1] + *root * (a[2] + *root * (a[3] + *root * a[4])))));
      return;
    }
    // The ray's direction as rho -> infinity: the highest non-zero coefficient's sign.
    int n = 4;
    while (n > 0 && a[n] == 0) --n;
    if (n >= 2) {
      theta_limit_ =
          a[n] > 0
              ? std::numbers::pi
              : std::atan2(kMaxRho, -(a[0] + kMaxRho * (a[1] + kMaxRho * (a[2] + kMaxRho * (a[3] + kMaxRho * a[4])))));
    } else {
      theta_limit_ = n == 1 ? std::atan2(1.0, -a[1]) : std::numbers::pi / 2;
    }
  }
  // The root of h in (0, rho_f] (or (0, infinity) without a fold); NaN where theta has none.
  double solve_rho(double theta) const {
    if (theta == 0) return 0;
    if (!(theta > 0)) return std::numeric_limits<double>::quiet_NaN();
    if (fold_rho_ && theta >= theta_limit_)
      return theta == theta_limit_ ? *fold_rho_ : std::numeric_limits<double>::quiet_NaN();
    const double c = std::cos(theta), s = std::sin(theta);
    double slope, lo = 0, hi;
    if (fold_rho_) {
      hi = *fold_rho_;
    } else {
      for (hi = std::max(1.0, -v_[0]); h(hi, c, s, &slope) < 0; hi *= 2) {
        if (hi > kMaxRho) return std::numeric_limits<double>::quiet_NaN();
      }
    }
    double r = theta < 1.5 ? -v_[0] * std::tan(theta) : 0.5 * hi;  // the pinhole's radius: close near the axis
    if (!(r > lo && r < hi)) r = 0.5 * (lo + hi);
    for (int iteration = 0; iteration < 200; ++iteration) {
      const double residual = h(r, c, s, &slope);
      if (residual == 0) return r;
      (residual < 0 ? lo : hi) = r;
      double next = r - residual / slope;
      if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
      if (std::abs(next - r) <= 1e-15 * r || hi - lo <= 4 * std::numeric_limits<double>::epsilon() * hi) return next;
      r = next;
    }
    return r;
  }

  std::array<Scalar, 5> a_;
  std::array<double, 5> v_{};  // a_'s values
  std::optional<double> fold_rho_;
  double theta_limit_ = std::numbers::pi / 2;
};

}  // namespace fishcam
