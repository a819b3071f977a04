// theta(rho): the valid domain of a radial model and its robust inversion.
//
// The valid domain is [0, theta_max] where theta_max is the smallest of the
// model's own limit, the first theta > 0 with drho/dtheta = 0 (a fold: past it
// two angles share one radius), and an optional user limit. On that domain rho
// is strictly increasing, so every rho in [0, rho_max] has exactly one theta.
#pragma once

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "fishcam/core/error.hpp"
#include "fishcam/core/radial_models.hpp"

namespace fishcam {

struct ValidDomain {
  // model: the model's own limit; fold: rho' = 0; user: theta_limit; distortion_fold:
  // where the non-radial part (tangential terms, an mrcal lens) stops being one-to-one (Camera).
  enum class Limit { model, fold, user, distortion_fold };
  double theta_max = 0;  // radians
  double rho_max = 0;    // rho(theta_max); +inf when the model diverges there
  bool closed = true;    // theta_max itself is valid (false: theta < theta_max only)
  Limit limited_by = Limit::model;
  // Cameras with a non-radial part (Camera): an upper bound on |D(m)| over the domain
  // (normalized plane units; +inf when open), so unprojection refuses what lies beyond
  // without solving.
  double plane_reach = std::numeric_limits<double>::infinity();

  bool contains_theta(double theta) const { return theta >= 0 && (closed ? theta <= theta_max : theta < theta_max); }
  bool contains_rho(double rho) const { return rho >= 0 && (closed ? rho <= rho_max : rho < rho_max); }
};

const char* to_string(ValidDomain::Limit limit);

// All complex roots of sum_i c[i] x^i (c[i] for i = 0..N, trailing zeros ignored),
// from the eigenvalues of the companion matrix.
std::vector<std::complex<double>> polynomial_roots(std::span<const double> coefficients);

// The least-squares y ~ sum_{k=first..last} c_k x^k over the samples (column-pivoting
// QR), its coefficients c_first..c_last and its largest residual |fit - y|.
struct PowerSeriesFit {
  std::vector<double> coefficients;
  double worst = 0;
};
PowerSeriesFit fit_power_series(std::span<const double> x, std::span<const double> y, int first, int last);

// first_positive_root (models/model_base.hpp): the smallest root in (0, limit].

// The first theta in (0, limit) where drho/dtheta stops being positive, found
// numerically (a scan of 4096 steps, then bisection to adjacent doubles): the fold
// search for models that are not polynomials in theta. nullopt if none.
template <class Model>
std::optional<double> first_fold(const Model& model, double limit);

// Valid domain of a model; nullopt user limit = none. Throws fishcam::Error when
// rho does not increase at theta = 0 or the user limit is not in (0, model limit].
template <class Model>
ValidDomain compute_domain(const Model& model, std::optional<double> user_limit);

// Bracketed Newton: the unique theta in the domain with rho(theta) = rho, to
// |rho(theta) - rho| <= 1e-10 px plus one final Newton step (or until the bracket
// collapses to adjacent doubles, for models too large to reach that). Converges
// from any start; a good initial guess (e.g. from the inverse table) only makes it
// faster. NaN for rho outside [0, rho_max], or NaN rho.
template <class Model>
double solve_theta(const Model& model, double rho, const ValidDomain& domain,
                   double initial_guess = std::numeric_limits<double>::quiet_NaN()) {
  if (!domain.contains_rho(rho)) return std::numeric_limits<double>::quiet_NaN();
  if constexpr (ClosedFormInverse<Model>) {
    if (domain.closed && rho == domain.rho_max) return domain.theta_max;  // a fold: the formula's sqrt(0 - ulps)
    return std::min(model.theta_from_rho(rho), domain.theta_max);         // min: rounding at rho_max
  } else {
    if (rho == 0) return 0;
    if (rho == domain.rho_max) return domain.theta_max;
    double lo = 0, hi = domain.theta_max;
    double theta = std::isnan(initial_guess) ? rho / model.drho(0.0) : initial_guess;
    if (!(theta > lo && theta < hi)) theta = 0.5 * (lo + hi);
    constexpr double kTolerancePx = 1e-10;
    for (int iteration = 0; iteration < 200; ++iteration) {
      double slope;
      const double residual = rho_and_drho(model, theta, &slope) - rho;
      if (residual == 0) return theta;
      (residual < 0 ? lo : hi) = theta;
      double next = theta - residual / slope;
      // Converged: the last Newton step costs nothing more and brings theta to
      // full precision even where rho' is small (near a fold).
      if (std::abs(residual) <= kTolerancePx) return next >= lo && next <= hi ? next : theta;
      if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);  // Newton left the bracket
      if (next == theta || hi - lo <= 4 * std::numeric_limits<double>::epsilon() * hi) return next;
      theta = next;
    }
    return theta;
  }
}

// The bulk path: a per-camera table over a uniform rho grid on [0, rho_max], cubic
// Hermite in each cell (values and exact slopes at the nodes), of theta and of the
// two numbers a unit ray needs, sin(theta)/rho and cos(theta) (so unprojecting an
// image needs no trigonometry). The error of every cell is measured when it is
// built, in pixels: |rho(theta_table) - rho| for theta, and the ray's angular
// error times rho'(theta) for the ray. Cells worse than the tolerance (next to a
// fold, where theta(rho) has a square-root singularity) are marked, and lookups
// there return false so the caller uses the robust solver.
class InverseTable {
 public:
  static constexpr double kDefaultTolerancePx = 1e-6;
  static constexpr int kDefaultCells = 2048;

  InverseTable() = default;
  template <class Model>
  InverseTable(const Model& model, const ValidDomain& domain, double tolerance_px = kDefaultTolerancePx,
               int cells = kDefaultCells);

  // theta for rho in [0, rho_max]; false if rho is outside the table or its cell
  // needs the robust solver (the output is then untouched).
  bool lookup(double rho, double* theta) const {
    double t;
    const double* c = cell(rho, theta_coefficients_, 4, &t);
    if (!c) return false;
    *theta = c[0] + t * (c[1] + t * (c[2] + t * c[3]));
    return true;
  }
  // sin(theta) / rho and cos(theta) for rho (the unit ray of image offset (x, y) is
  // (x s, y s, c)); false like lookup().
  bool lookup_ray(double rho, double* sin_theta_over_rho, double* cos_theta) const {
    double t;
    const double* c = cell(rho, ray_coefficients_, 8, &t);
    if (!c) return false;
    *sin_theta_over_rho = c[0] + t * (c[1] + t * (c[2] + t * c[3]));
    *cos_theta = c[4] + t * (c[5] + t * (c[6] + t * c[7]));
    return true;
  }

  bool empty() const { return cells_ == 0; }
  int cells() const { return cells_; }
  int fallback_cells() const { return fallback_cells_; }
  // Largest measured error (px) over the cells in use, for theta and for rays.
  double worst_error_px() const { return worst_error_px_; }
  double worst_ray_error_px() const { return worst_ray_error_px_; }
  double tolerance_px() const { return tolerance_px_; }

 private:
  // The coefficients of rho's cell (nullptr outside the table or in a marked cell)
  // and rho's position t in [0, 1] inside it.
  const double* cell(double rho, const std::vector<double>& coefficients, int stride, double* t) const {
    const double x = rho * inverse_step_;
    if (!(x >= 0 && x <= last_)) return nullptr;
    int index = static_cast<int>(x);
    index -= index == cells_;  // rho == rho_max belongs to the last cell
    const double* c = &coefficients[static_cast<size_t>(stride) * static_cast<size_t>(index)];
    if (std::isnan(c[0])) return nullptr;
    *t = x - index;
    return c;
  }

  std::vector<double> theta_coefficients_;  // 4 per cell: c0 + c1 t + c2 t^2 + c3 t^3, t in [0, 1]
  std::vector<double> ray_coefficients_;    // 8 per cell: sin(theta)/rho, then cos(theta)
  double inverse_step_ = 0;
  double last_ = -1;  // cells_ as double, the largest valid x
  int cells_ = 0;
  int fallback_cells_ = 0;
  double worst_error_px_ = 0;
  double worst_ray_error_px_ = 0;
  double tolerance_px_ = kDefaultTolerancePx;
};

// ---------------------------------------------------------------- definitions
// In the header so that every model of the registry instantiates them.

// The first theta in (0, limit) where rho' stops being positive, for models that
// are not polynomials in theta: rho' sampled on a fine grid, the first sample
// that is not positive bracketed and bisected to adjacent doubles.
template <class Model>
std::optional<double> first_fold(const Model& model, double limit) {
  constexpr int kSamples = 4096;
  double lo = 0;
  for (int i = 1; i < kSamples; ++i) {
    const double theta = limit * i / kSamples;
    if (model.drho(theta) > 0) {
      lo = theta;
      continue;
    }
    double hi = theta;
    while (true) {
      const double mid = 0.5 * (lo + hi);
      if (mid <= lo || mid >= hi) break;
      (model.drho(mid) > 0 ? lo : hi) = mid;
    }
    return lo;
  }
  return std::nullopt;
}

template <class Model>
ValidDomain compute_domain(const Model& model, std::optional<double> user_limit) {
  constexpr double kDeg = 180 / std::numbers::pi;
  const double slope0 = model.drho(0.0);
  if (!std::isfinite(slope0)) {  // e.g. N * kN overflows
    throw Error(std::string(Model::kName) + ": coefficients too large (drho/dtheta overflows)");
  }
  if (!(slope0 > 0)) {
    std::ostringstream msg;
    msg << Model::kName << ": rho must increase at theta = 0 (drho/dtheta(0) = " << slope0 << "); "
        << (std::is_same_v<Model, Polynomial<double>> ? "k1 must be > 0" : "f must be > 0");
    throw Error(msg.str());
  }
  const double model_limit = model.theta_limit();
  const bool model_open = model.limit_is_open();
  ValidDomain domain{model_limit, 0, !model_open, ValidDomain::Limit::model};
  // A closed limit where rho' vanishes is a fold the model located in closed form.
  if (!model_open && std::abs(model.drho(model_limit)) <= 1e-6 * slope0) domain.limited_by = ValidDomain::Limit::fold;
  std::optional<double> fold;
  if constexpr (PolynomialInTheta<Model>) {
    const std::vector<double> c = model.power_coefficients();
    std::vector<double> derivative(c.size() - 1);
    for (size_t i = 0; i + 1 < c.size(); ++i) derivative[i] = double(i + 1) * c[i + 1];
    fold = first_positive_root(derivative, domain.theta_max);
  } else {
    fold = first_fold(model, domain.theta_max);
  }
  if (fold && *fold < domain.theta_max) {
    domain.theta_max = *fold;
    domain.closed = true;
    domain.limited_by = ValidDomain::Limit::fold;
  }
  if (user_limit) {
    const double limit = *user_limit;
    const bool in_range = model_open ? limit < model_limit : limit <= model_limit;
    if (!(limit > 0) || !in_range) {
      std::ostringstream msg;
      msg.precision(15);  // 180.0000001 must not print as 180
      msg << "theta_limit: must be in (0, " << model_limit * kDeg << (model_open ? ")" : "]") << " degrees for "
          << Model::kName << ", got " << limit * kDeg;
      throw Error(msg.str());
    }
    if (limit < domain.theta_max || (limit == domain.theta_max && !domain.closed)) {
      domain = {limit, 0, true, ValidDomain::Limit::user};
    }
  }
  domain.rho_max = domain.closed ? model.rho(domain.theta_max) : std::numeric_limits<double>::infinity();
  if (domain.closed && !(domain.rho_max > 0 && std::isfinite(domain.rho_max))) {
    std::ostringstream msg;
    msg << Model::kName << ": rho(theta_max) = " << domain.rho_max << " is not a finite positive radius";
    throw Error(msg.str());
  }
  return domain;
}

namespace detail {

// Power coefficients of the cubic Hermite interpolant on t in [0, 1] from the end
// values v and slopes m (per unit t).
inline void hermite(double v0, double m0, double v1, double m1, double* c) {
  c[0] = v0;
  c[1] = m0;
  c[2] = -3 * v0 - 2 * m0 + 3 * v1 - m1;
  c[3] = 2 * v0 + m0 - 2 * v1 + m1;
}

inline double cubic(const double* c, double t) { return c[0] + t * (c[1] + t * (c[2] + t * c[3])); }

}  // namespace detail

template <class Model>
InverseTable::InverseTable(const Model& model, const ValidDomain& domain, double tolerance_px, int cells)
    : tolerance_px_(tolerance_px) {
  if (cells < 1 || !(tolerance_px > 0)) throw Error("inverse table: needs >= 1 cell and a positive tolerance");
  const double range = domain.closed ? domain.rho_max : 0.0;
  if (!(range > 0 && std::isfinite(range))) return;  // open domain: callers use the closed form
  const double step = range / cells;
  // Node values and slopes (d/dt = step * d/drho) of theta, sin(theta)/rho, cos(theta).
  struct Node {
    double theta, dtheta, s, ds, c, dc;
  };
  // At rho = 0: sin(theta)/rho -> 1/rho'(0), slope -rho''(0) / (2 rho'(0)^3).
  const double a = model.drho(0.0), delta = 1e-4;
  const double second = (model.drho(delta) - model.drho(-delta)) / (2 * delta);
  std::vector<Node> nodes(cells + 1);
  for (int i = 0; i <= cells; ++i) {
    const double rho = i == cells ? domain.rho_max : step * i;
    const double theta = solve_theta(model, rho, domain);
    const double dtheta = 1 / model.drho(theta);  // infinite at a fold
    const double sin = std::sin(theta), cos = std::cos(theta);
    Node& n = nodes[i];
    n.theta = theta, n.dtheta = step * dtheta;
    n.c = cos, n.dc = -step * sin * dtheta;
    n.s = rho > 0 ? sin / rho : 1 / a;
    n.ds = rho > 0 ? step * (cos * dtheta * rho - sin) / (rho * rho) : -step * second / (2 * a * a * a);
  }
  theta_coefficients_.resize(4 * static_cast<size_t>(cells));
  ray_coefficients_.resize(8 * static_cast<size_t>(cells));
  constexpr int kSamples = 8;
  for (int i = 0; i < cells; ++i) {
    double* ct = &theta_coefficients_[4 * static_cast<size_t>(i)];
    double* cr = &ray_coefficients_[8 * static_cast<size_t>(i)];
    const Node &n0 = nodes[i], &n1 = nodes[i + 1];
    detail::hermite(n0.theta, n0.dtheta, n1.theta, n1.dtheta, ct);
    detail::hermite(n0.s, n0.ds, n1.s, n1.ds, cr);
    detail::hermite(n0.c, n0.dc, n1.c, n1.dc, cr + 4);
    double worst = 0, worst_ray = 0;
    for (int k = 0; k <= kSamples; ++k) {
      const double t = double(k) / kSamples, rho = step * (i + t);
      const double theta_error = std::abs(model.rho(detail::cubic(ct, t)) - rho);
      // The ray's angle error, from its components against the exact angle, in px.
      const double exact = solve_theta(model, rho, domain);
      const double ray_error = std::max(std::abs(detail::cubic(cr, t) * rho - std::sin(exact)),
                                        std::abs(detail::cubic(cr + 4, t) - std::cos(exact))) *
                               model.drho(exact);
      worst = std::isfinite(theta_error) ? std::max(worst, theta_error) : INFINITY;
      worst_ray = std::isfinite(ray_error) ? std::max(worst_ray, ray_error) : INFINITY;
    }
    if (worst > tolerance_px || worst_ray > tolerance_px) {
      ct[0] = cr[0] = std::numeric_limits<double>::quiet_NaN();
      ++fallback_cells_;
    } else {
      worst_error_px_ = std::max(worst_error_px_, worst);
      worst_ray_error_px_ = std::max(worst_ray_error_px_, worst_ray);
    }
  }
  cells_ = cells;
  inverse_step_ = 1 / step;
  last_ = cells;
}

}  // namespace fishcam
