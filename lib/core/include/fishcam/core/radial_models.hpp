// Radial projection models rho(theta): image distance from the principal point
// (in pixel-scale units, see docs/conventions.md) as a function of the angle of
// incidence theta. The list of models is in fishcam/core/model_registry.hpp, which
// says how to add one.
//
// One small class per model, templated on the scalar type so that Ceres can
// differentiate through them (ceres::Jet). Math calls are unqualified after a
// `using std::...` so that ADL picks the Jet overloads.
//
// Each model provides
//   kName, kParamNames               its name (CLI, files, Python) and parameters, in order
//   Model(const Scalar* p, int n)    from its parameters (n: their count; checked by the registry)
//   params()                         the parameters in that order
//   invalid()                        what is wrong with the parameters ("" if nothing); the
//                                    registry and Camera refuse a model with a problem
//   rho(theta), drho(theta)          the model and its analytic derivative
//   (optionally rho(theta, &drho)    both at once, where that is cheaper)
//   theta_limit(), limit_is_open()   where the model itself stops: theta < limit (open) or
//                                    <= limit (closed). Closed-form models include their own
//                                    folds here; compute_domain() also searches for folds
//   scaled(s)                        the model for s * rho(theta), exactly
//   initial_params(f)                a start whose rho'(0) = f (fitting, calibration)
// and optionally
//   theta_from_rho(rho)              a closed-form inverse on the valid domain
//   power_coefficients()             rho as a polynomial in theta (exact fold search)
//   basis(theta, n, g), from_basis   rho linear in the parameters: exact linear fits
//   fit_starts(f), param_bounds(i)   otherwise: where the non-linear fit starts, and its bounds
//   unified_form()                   the float warp kernel's unified-camera form (below)
//   from_paper(rho, theta)           the paper's closed-form conversion (its eqs. 13-14): the
//                                    model whose image has radius rho at angle theta
//   kTakesOrder                      the model's name takes a parameter count ("polynomial:6")
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

namespace fishcam {

// The unified-camera family in one form (the float warp kernel's): for a point P
// with chi = |P_xy|, n = |P| and w = xi n + P_z,
//   D = alpha sqrt(beta chi^2 + w^2) + (1 - alpha) w,   r = chi / D,   s = r^2,
//   rho / chi = f (1 + k1 s + k2 s^2 + k3 s^3) / ((1 + k4 s + k5 s^2 + k6 s^3) D).
// Pinhole, stereographic, unified, extended-unified, double-sphere, mei and opencv
// (xi = alpha = 0: r = tan(theta)) are all special cases (docs/conventions.md).
struct UnifiedForm {
  double f = 1, xi = 0, alpha = 0, beta = 1, k1 = 0, k2 = 0, k3 = 0, k4 = 0, k5 = 0, k6 = 0;
};

// The smallest root in (0, limit] of sum_i c[i] x^i, exactly (companion-matrix roots
// polished by bracketed Newton, cross-checked by a sign scan); nullopt if none.
std::optional<double> first_positive_root(std::span<const double> coefficients, double limit);

namespace detail {
inline constexpr double kInf = std::numeric_limits<double>::infinity();
// "" or "NAME: must be ..." (the registry prefixes the model name).
inline std::string require(bool ok, std::string_view message) { return ok ? "" : std::string(message); }
}  // namespace detail

namespace detail {
// The value of a double or of a ceres::Jet (its scalar part).
template <typename Scalar>
double value_of(const Scalar& x) {
  if constexpr (std::is_arithmetic_v<Scalar>) {
    return double(x);
  } else {
    return value_of(x.a);
  }
}
}  // namespace detail

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

// rho = f * theta.
template <typename Scalar>
class Equidistant {
 public:
  static constexpr std::string_view kName = "equidistant";
  static constexpr std::array<std::string_view, 1> kParamNames{"f"};

  Equidistant() = default;
  explicit Equidistant(Scalar f) : f_(f) {}
  Equidistant(const Scalar* p, int) : f_(p[0]) {}

  std::string invalid() const { return ""; }  // f > 0: compute_domain's slope check
  Scalar rho(const Scalar& theta) const { return f_ * theta; }
  Scalar drho(const Scalar&) const { return f_; }
  Scalar theta_from_rho(const Scalar& rho) const { return rho / f_; }
  static constexpr double theta_limit() { return std::numbers::pi; }
  static constexpr bool limit_is_open() { return false; }
  Equidistant scaled(const Scalar& s) const { return Equidistant(f_ * s); }
  // Eq. 13: f = rho / theta.
  static Equidistant from_paper(double rho, double theta) { return Equidistant(Scalar(rho / theta)); }
  std::vector<Scalar> power_coefficients() const { return {Scalar(0), f_}; }
  std::vector<Scalar> params() const { return {f_}; }
  const Scalar& f() const { return f_; }

  static std::vector<double> initial_params(double f, int) { return {f}; }
  static void basis(double theta, int, double* g) { g[0] = theta; }
  static std::vector<double> from_basis(const double* p, int) { return {p[0]}; }

 private:
  Scalar f_{1};
};

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

// OpenCV's pinhole model with its rational radial distortion (cv::projectPoints'
// k1..k6; mrcal's LENSMODEL_OPENCV4/5/8 without the tangential terms): with
// r = tan(theta) and s = r^2,
//   rho = f r (1 + k1 s + k2 s^2 + k3 s^3) / (1 + k4 s + k5 s^2 + k6 s^3).
// Parameters f, k1, k2, k3, k4, k5, k6 (OpenCV's fx, fy map to f = fx, a_y = fy / fx).
// Valid: theta < pi/2 and below the first pole of the denominator (open), up to the
// first fold (found by compute_domain's scan, closed there).
template <typename Scalar>
class OpenCV {
 public:
  static constexpr std::string_view kName = "opencv";
  static constexpr std::array<std::string_view, 7> kParamNames{"f", "k1", "k2", "k3", "k4", "k5", "k6"};

  OpenCV() = default;
  explicit OpenCV(const Scalar* p, int = 7) : p_{p[0], p[1], p[2], p[3], p[4], p[5], p[6]} {}
  OpenCV(Scalar f, Scalar k1, Scalar k2, Scalar k3, Scalar k4 = Scalar(0), Scalar k5 = Scalar(0), Scalar k6 = Scalar(0))
      : p_{f, k1, k2, k3, k4, k5, k6} {}

  std::string invalid() const { return ""; }
  // The radial distortion factor N(s) / D(s) of the undistorted radius r = tan(theta).
  Scalar distortion(const Scalar& s) const {
    return (Scalar(1) + s * (p_[1] + s * (p_[2] + s * p_[3]))) / (Scalar(1) + s * (p_[4] + s * (p_[5] + s * p_[6])));
  }
  Scalar rho(const Scalar& theta) const {
    using std::tan;
    const Scalar r = tan(theta);
    return p_[0] * r * distortion(r * r);
  }
  Scalar rho(const Scalar& theta, Scalar* drho) const {
    using std::tan;
    const Scalar r = tan(theta), s = r * r;
    const Scalar n = Scalar(1) + s * (p_[1] + s * (p_[2] + s * p_[3]));
    const Scalar d = Scalar(1) + s * (p_[4] + s * (p_[5] + s * p_[6]));
    const Scalar dn = p_[1] + s * (Scalar(2) * p_[2] + s * Scalar(3) * p_[3]);
    const Scalar dd = p_[4] + s * (Scalar(2) * p_[5] + s * Scalar(3) * p_[6]);
    // d/dtheta [r n / d] = (1 + s) [n / d + 2 s (n' d - n d') / d^2]
    *drho = p_[0] * (Scalar(1) + s) * (n / d + Scalar(2) * s * (dn * d - n * dd) / (d * d));
    return p_[0] * r * n / d;
  }
  Scalar drho(const Scalar& theta) const {
    Scalar d;
    rho(theta, &d);
    return d;
  }
  double theta_limit() const {
    // Poles in s = tan^2(theta) up to 1e12 (theta = 90 - 6e-5 degrees).
    const double d[4] = {1, double(p_[4]), double(p_[5]), double(p_[6])};
    const std::optional<double> pole = first_positive_root(d, 1e12);
    return pole ? std::atan(std::sqrt(*pole)) : std::numbers::pi / 2;
  }
  static constexpr bool limit_is_open() { return true; }
  OpenCV scaled(const Scalar& s) const {
    OpenCV out = *this;
    out.p_[0] = out.p_[0] * s;
    return out;
  }
  std::vector<Scalar> params() const { return {p_[0], p_[1], p_[2], p_[3], p_[4], p_[5], p_[6]}; }
  UnifiedForm unified_form() const {
    return {double(p_[0]), 0, 0, 1, double(p_[1]), double(p_[2]), double(p_[3]), double(p_[4]), double(p_[5]),
            double(p_[6])};
  }

  // The undistorted plane m = (X, Y) / Z (fishcam/core/tangential.hpp): R = N / D.
  static constexpr bool kTakesTangentialTerms = true;
  double focal() const { return double(p_[0]); }
  static double plane_radius(double theta, double* derivative) {
    return Pinhole<double>::plane_radius(theta, derivative);
  }
  static double theta_of_plane_radius(double r) { return std::atan(r); }
  double radial_factor(double s, double* derivative) const {
    const double k[7] = {double(p_[0]), double(p_[1]), double(p_[2]), double(p_[3]),
                         double(p_[4]), double(p_[5]), double(p_[6])};
    const double n = 1 + s * (k[1] + s * (k[2] + s * k[3])), d = 1 + s * (k[4] + s * (k[5] + s * k[6]));
    const double dn = k[1] + s * (2 * k[2] + s * 3 * k[3]), dd = k[4] + s * (2 * k[5] + s * 3 * k[6]);
    *derivative = (dn * d - n * dd) / (d * d);
    return n / d;
  }

  static std::vector<double> initial_params(double f, int) { return {f, 0, 0, 0, 0, 0, 0}; }
  static std::vector<std::vector<double>> fit_starts(double f) { return {{f, 0, 0, 0, 0, 0, 0}}; }
  static std::pair<double, double> param_bounds(int i) {
    if (i == 0) return {0.0, detail::kInf};
    return {-detail::kInf, detail::kInf};
  }

 private:
  Scalar p_[7]{Scalar(1), Scalar(0), Scalar(0), Scalar(0), Scalar(0), Scalar(0), Scalar(0)};
};

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

// ---------------------------------------------------------------------------
// The unified-camera family (Geyer & Daniilidis, Mei & Rives, Khomenko et al.,
// Usenko et al. 2018). On a unit ray (sin(theta), 0, cos(theta)) each is
// rho = f sin(theta) / D(theta); the valid domains below are where that is
// defined and strictly increasing, in closed form (docs/conventions.md derives them).

namespace detail {
// theta where the direction of q = (sin(theta), cos(theta) + xi) has cos = -w, for
// |xi| < 1 or xi >= 0 up to the fold (the double sphere's shift; xi = 0: acos(-w)).
inline double theta_of_shifted_direction(double xi, double w) {
  const double cos_phi = -w, sin_phi = std::sqrt(std::max(0.0, 1 - w * w));
  const double t = xi * cos_phi + std::sqrt(std::max(0.0, xi * xi * cos_phi * cos_phi - xi * xi + 1));
  return std::atan2(t * sin_phi, t * cos_phi - xi);
}
// sqrt of a difference that rounding may push a few ulps below 0 at a fold.
template <typename Scalar>
Scalar sqrt_nonnegative(const Scalar& x) {
  using std::sqrt;
  return x > Scalar(0) ? sqrt(x) : Scalar(0);
}
// One Newton step on rho(theta) = rho from a closed-form theta: the unified family's
// formulas lose digits next to a fold (a square root of a small difference).
template <class Model, typename Scalar>
Scalar newton_polish(const Model& model, const Scalar& theta, const Scalar& rho) {
  const Scalar slope = model.drho(theta);
  const Scalar next = theta - (model.rho(theta) - rho) / slope;
  return next == next && slope > Scalar(0) ? next : theta;  // NaN or a fold: keep the formula's value
}
// The alpha form's limit on cos of q's direction: -w1 (a pole for alpha <= 1/2, else a fold).
inline double alpha_w1(double alpha) { return alpha <= 0.5 ? alpha / (1 - alpha) : (1 - alpha) / alpha; }
}  // namespace detail

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

template <class Model>
concept ClosedFormInverse = requires(const Model& m, double r) {
  m.theta_from_rho(r);
};

template <class Model>
concept FusedDerivative = requires(const Model& m, double t, double* d) {
  m.rho(t, d);
};

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
concept PolynomialInTheta = requires(const Model& m) {
  m.power_coefficients();
};

// rho = sum_j p_j g_j(theta): fitted exactly by linear least squares.
template <class Model>
concept LinearInParams = requires(double t, double* g, const double* p) {
  Model::basis(t, 1, g);
  Model::from_basis(p, 1);
};

template <class Model>
concept HasUnifiedForm = requires(const Model& m) {
  m.unified_form();
};

// rho(theta) defined by a ray polynomial (ocam): the float kernel solves for it.
template <class Model>
concept HasRayPolynomial = requires(const Model& m) {
  m.ray_polynomial();
};

// Models with an undistorted plane on which tangential terms can be added
// (fishcam/core/tangential.hpp): rho(theta) = f u(theta) R(u(theta)^2) with u the plane
// radius (plane_radius gives u and du/dtheta, theta_of_plane_radius inverts it on
// the model's domain) and R the radial factor (radial_factor gives R and dR/ds).
template <class Model>
concept HasUndistortedPlane = requires(const Model& m, double x, double* d) {
  m.focal();
  m.plane_radius(x, d);
  m.theta_of_plane_radius(x);
  m.radial_factor(x, d);
};

// The models whose plane takes OpenCV's tangential terms (pinhole, opencv, mei; the
// stereographic plane takes mrcal's spline instead).
template <class Model>
concept TakesTangentialTerms = HasUndistortedPlane<Model> && requires {
  Model::kTakesTangentialTerms;
};

}  // namespace fishcam
