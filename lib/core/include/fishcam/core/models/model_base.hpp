// What every radial model shares: the unified-camera form of the float kernel, the
// root finder of polynomial models, the unified family's helpers, and the traits
// generic code asks a model for (fishcam/core/radial_models.hpp lists a model's
// members; one header per model beside this one).
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
concept TakesTangentialTerms = HasUndistortedPlane<Model> && requires(const Model& m, const double* p, double* q) {
  Model::kTakesTangentialTerms;
  m.plane_point(p, q);  // m and f for a point, generic in the scalar type
};

}  // namespace fishcam
